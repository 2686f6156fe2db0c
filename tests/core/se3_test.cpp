#include "core/common/se3.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace lidarfuse::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(Se3, So3ExpKnownValues) {
    // 90 degrees about z maps x to y.
    const Eigen::Matrix3d R = so3_exp(Eigen::Vector3d(0, 0, kPi / 2));
    EXPECT_TRUE((R * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
    EXPECT_TRUE(so3_exp(Eigen::Vector3d::Zero()).isIdentity(0.0));
    // Agrees with Eigen's AngleAxis for a generic vector.
    const Eigen::Vector3d w(0.3, -0.7, 1.1);
    const Eigen::Matrix3d expected = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
    EXPECT_TRUE(so3_exp(w).isApprox(expected, 1e-12));
}

TEST(Se3, So3LogRoundTripIncludingSmallAndNearPi) {
    std::mt19937 rng(7);
    std::normal_distribution<double> g(0.0, 1.0);
    for (const double angle : {0.0, 1e-12, 1e-8, 1e-5, 1e-3, 0.5, 2.0, 3.0, kPi - 1e-6}) {
        for (int i = 0; i < 5; ++i) {
            const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
            const Eigen::Vector3d w = angle * axis;
            const Eigen::Vector3d back = so3_log(so3_exp(w));
            EXPECT_TRUE(back.allFinite());
            EXPECT_NEAR((back - w).norm(), 0.0, 1e-9 + 1e-9 * angle) << "angle " << angle;
        }
    }
    // Exactly pi: the axis is recovered up to sign.
    const Eigen::Vector3d w(0, kPi, 0);
    const Eigen::Vector3d back = so3_log(so3_exp(w));
    EXPECT_NEAR(back.norm(), kPi, 1e-9);
    EXPECT_NEAR(std::abs(back.y()), kPi, 1e-9);
}

TEST(Se3, Se3ExpKnownValueAndRoundTrip) {
    // Pure translation.
    Vector6d xi = Vector6d::Zero();
    xi.tail<3>() = Eigen::Vector3d(1, 2, 3);
    EXPECT_TRUE(se3_exp(xi).translation().isApprox(Eigen::Vector3d(1, 2, 3), 1e-15));
    // A screw motion: rotate pi/2 about z while moving v = (0, 0, 1) along the axis ->
    // translation (0, 0, 1) exactly (V leaves the axis direction unchanged).
    xi << 0, 0, kPi / 2, 0, 0, 1;
    EXPECT_TRUE(se3_exp(xi).translation().isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
    // v = (1, 0, 0) with omega = pi/2 about z: t = V v = (sin(th)/th, (1-cos(th))/th, 0).
    xi << 0, 0, kPi / 2, 1, 0, 0;
    const double th = kPi / 2;
    EXPECT_TRUE(se3_exp(xi).translation().isApprox(
        Eigen::Vector3d(std::sin(th) / th, (1 - std::cos(th)) / th, 0), 1e-12));

    std::mt19937 rng(11);
    std::normal_distribution<double> g(0.0, 1.0);
    for (int i = 0; i < 50; ++i) {
        Vector6d x;
        for (int k = 0; k < 6; ++k) x(k) = g(rng);
        // log returns angles in [0, pi]: keep the test rotations inside that range.
        if (x.head<3>().norm() > 3.0) x.head<3>() *= 3.0 / x.head<3>().norm();
        if (i % 5 == 0) x.head<3>() *= 1e-9;  // near-zero rotation
        const Vector6d back = se3_log(se3_exp(x));
        EXPECT_LT((back - x).norm(), 1e-9) << x.transpose();
    }
}

TEST(Se3, RotationAngleAndErrors) {
    const Eigen::Matrix3d Ra = so3_exp(Eigen::Vector3d(0.1, 0.2, 0.3));
    const Eigen::Matrix3d Rb = Ra * so3_exp(Eigen::Vector3d(0, 0, 0.05));
    EXPECT_NEAR(rotation_angle_rad(Ra, Rb), 0.05, 1e-12);
    EXPECT_NEAR(rotation_angle_deg(Ra, Rb), 0.05 * 180 / kPi, 1e-10);
    // Tiny angles are resolved (an acos form would give 0 or noise here).
    const Eigen::Matrix3d Rc = Ra * so3_exp(Eigen::Vector3d(1e-9, 0, 0));
    EXPECT_NEAR(rotation_angle_rad(Ra, Rc), 1e-9, 1e-15);
    EXPECT_NEAR(rotation_angle_rad(Ra, Ra), 0.0, 1e-15);

    Eigen::Isometry3d A = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d B = Eigen::Isometry3d::Identity();
    B.translation() = Eigen::Vector3d(3, 4, 0);
    B.linear() = so3_exp(Eigen::Vector3d(0, 0, kPi / 4));
    EXPECT_NEAR(translation_error_m(A, B), 5.0, 1e-12);
    EXPECT_NEAR(rotation_error_deg(A, B), 45.0, 1e-10);
    EXPECT_NEAR(rotation_error_rad(B, A), kPi / 4, 1e-12);
}

TEST(Se3, QuaternionRoundTripCanonicalSign) {
    const Eigen::Quaterniond q(-0.5, 0.5, -0.5, 0.5);  // w < 0
    const Eigen::Isometry3d T = isometry_from_quaternion(q, Eigen::Vector3d(1, 2, 3));
    const Eigen::Quaterniond back = quaternion_of(T);
    EXPECT_GE(back.w(), 0.0);
    EXPECT_TRUE(back.coeffs().isApprox(-q.coeffs(), 1e-12));
    EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
    // Unnormalised input is normalised.
    const Eigen::Isometry3d U = isometry_from_quaternion(Eigen::Quaterniond(2, 0, 0, 0), {0, 0, 0});
    EXPECT_TRUE(U.linear().isIdentity(1e-15));
}

TEST(Se3, OrthonormalizedRepairsDrift) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = so3_exp(Eigen::Vector3d(0.4, -0.2, 0.9));
    T.linear()(0, 1) += 1e-6;
    const Eigen::Isometry3d F = orthonormalized(T);
    EXPECT_TRUE((F.linear() * F.linear().transpose()).isIdentity(1e-14));
    EXPECT_NEAR(F.linear().determinant(), 1.0, 1e-14);
    EXPECT_LT((F.linear() - T.linear()).norm(), 1e-6);
}

TEST(Se3, AverageOfSymmetricPerturbationsIsTheCentre) {
    Eigen::Isometry3d centre = Eigen::Isometry3d::Identity();
    centre.linear() = so3_exp(Eigen::Vector3d(0.3, 0.1, -0.5));
    centre.translation() = Eigen::Vector3d(1, -2, 0.5);
    std::vector<Eigen::Isometry3d> poses;
    for (int axis = 0; axis < 3; ++axis) {
        for (const double s : {-1.0, 1.0}) {
            Vector6d xi = Vector6d::Zero();
            xi(axis) = 0.2 * s;
            xi(3 + axis) = 0.5 * s;
            Eigen::Isometry3d T = centre;
            T.linear() = centre.linear() * so3_exp(xi.head<3>());
            T.translation() += xi.tail<3>();
            poses.push_back(T);
        }
    }
    const Eigen::Isometry3d mean = average_poses(poses);
    EXPECT_LT(rotation_error_rad(mean, centre), 1e-10);
    EXPECT_LT(translation_error_m(mean, centre), 1e-12);
    EXPECT_TRUE(average_poses({}).isApprox(Eigen::Isometry3d::Identity()));
}

}  // namespace
}  // namespace lidarfuse::core
