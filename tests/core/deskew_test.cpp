#include "core/preprocess/deskew.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace lidarfuse::core {
namespace {

Eigen::Isometry3d pose_at(double t) {
    // A pole head swaying: 0.5 m/s sideways, 2 deg/s about x, plus a small yaw rate.
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(0.035 * t, Eigen::Vector3d::UnitX()) *
                  Eigen::AngleAxisd(0.01 * t, Eigen::Vector3d::UnitZ()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.1, 0.5 * t, 6.0);
    return T;
}

// World points seen by a moving sensor at different instants come back, after deskew, at
// the place the sensor at t_ref would have seen them.
TEST(Deskew, ConstantTwistRestoresTheReferenceFrame) {
    const double t_ref = 1.0;
    std::vector<Eigen::Vector3d> world, points;
    std::vector<float> dt;
    for (int col = 0; col < 1024; ++col) {
        const double t = t_ref + col * 0.05 / 1024;
        const Eigen::Vector3d w(10 * std::cos(col * 0.006), 10 * std::sin(col * 0.006), 0.0);
        world.push_back(w);
        points.push_back(pose_at(t).inverse() * w);  // measured in the sensor frame at t
        dt.push_back(static_cast<float>(t - t_ref));
    }
    // The motion model: twist from two earlier poses, as the engine does.
    const Vector6d xi = body_twist_per_s(pose_at(t_ref - 0.05), pose_at(t_ref), 0.05);
    double before = 0, after = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        before = std::max(before, (pose_at(t_ref) * points[i] - world[i]).norm());
    }
    deskew_points(xi, dt, &points);
    for (std::size_t i = 0; i < points.size(); ++i) {
        after = std::max(after, (pose_at(t_ref) * points[i] - world[i]).norm());
    }
    EXPECT_GT(before, 0.02);  // 2.5 cm smear over the sweep without deskew
    EXPECT_LT(after, 2e-4);   // only the model's second-order error remains
}

TEST(Deskew, ZeroTwistOrMismatchedTimesLeavePointsAlone) {
    std::vector<Eigen::Vector3d> points = {{1, 2, 3}, {4, 5, 6}};
    const auto copy = points;
    deskew_points(Vector6d::Zero(), {0.01f, 0.02f}, &points);
    EXPECT_EQ(points, copy);
    Vector6d xi = Vector6d::Zero();
    xi(3) = 1.0;
    deskew_points(xi, {0.01f}, &points);  // one time for two points: ignored
    EXPECT_EQ(points, copy);
    EXPECT_TRUE(body_twist_per_s(pose_at(0), pose_at(1), 0.0).isZero());
}

// The per-point series form (small rotation over the sweep) and the exact exponential
// (larger rotations) both agree with se3_exp applied point by point.
TEST(Deskew, SeriesAndExactFormsMatchTheExponential) {
    for (const double rate_rad_s : {0.05, 0.19, 2.0}) {  // 0.05 s sweep: 2.5, 9.5, 100 mrad
        Vector6d xi;
        xi << rate_rad_s * 0.6, -rate_rad_s * 0.8, rate_rad_s * 0.3, 0.4, -0.3, 0.05;
        std::vector<Eigen::Vector3d> points, expected;
        std::vector<float> dt;
        for (int k = 0; k < 2048; ++k) {
            const float t = static_cast<float>((k % 1024) * 0.05 / 1024);  // row-major order
            const Eigen::Vector3d p(40 * std::cos(k * 0.01), 40 * std::sin(k * 0.01), -5.0 + k % 7);
            points.push_back(p);
            dt.push_back(t);
            expected.push_back(se3_exp(xi * static_cast<double>(t)) * p);
        }
        deskew_points(xi, dt, &points);
        double worst_m = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            worst_m = std::max(worst_m, (points[i] - expected[i]).norm());
        }
        EXPECT_LT(worst_m, 1e-5) << rate_rad_s;  // 40 m range: 0.25 urad
    }
}

}  // namespace
}  // namespace lidarfuse::core
