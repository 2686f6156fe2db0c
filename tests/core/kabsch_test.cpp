#include "core/registration/kabsch.hpp"

#include <gtest/gtest.h>

#include <random>

namespace lidarfuse::core {
namespace {

Eigen::Isometry3d make_transform(double yaw, double pitch, double roll, const Eigen::Vector3d& t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = t;
    return T;
}

TEST(Kabsch, RecoversExactTransform) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-10.0, 10.0);
    const Eigen::Isometry3d T = make_transform(2.5, 0.3, -0.2, Eigen::Vector3d(4, -7, 1.5));
    std::vector<Eigen::Vector3d> source, target;
    for (int i = 0; i < 50; ++i) {
        source.emplace_back(u(rng), u(rng), u(rng));
        target.push_back(T * source.back());
    }
    const KabschResult r = estimate_rigid_transform(source, target);
    ASSERT_TRUE(r.valid);
    EXPECT_TRUE(r.T_target_source.isApprox(T, 1e-9));
    EXPECT_LT(r.rms_error_m, 1e-9);
    EXPECT_NEAR(r.T_target_source.linear().determinant(), 1.0, 1e-12);
}

TEST(Kabsch, NoisyFitIsLeastSquares) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-5.0, 5.0);
    std::normal_distribution<double> noise(0.0, 0.01);
    const Eigen::Isometry3d T = make_transform(-1.0, 0.05, 0.1, Eigen::Vector3d(1, 2, 3));
    std::vector<Eigen::Vector3d> source, target;
    for (int i = 0; i < 2000; ++i) {
        source.emplace_back(u(rng), u(rng), u(rng));
        target.push_back(T * source.back() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    }
    const KabschResult r = estimate_rigid_transform(source, target);
    ASSERT_TRUE(r.valid);
    EXPECT_LT((r.T_target_source.translation() - T.translation()).norm(), 2e-3);
    EXPECT_NEAR(r.rms_error_m, 0.01 * std::sqrt(3.0), 2e-3);
}

// A target that is a mirror image of the source: the unconstrained SVD solution would be a
// reflection; the fix must return a proper rotation instead.
TEST(Kabsch, ReflectionIsFixedToProperRotation) {
    std::vector<Eigen::Vector3d> source{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    std::vector<Eigen::Vector3d> target;
    for (const auto& p : source) target.emplace_back(p.x(), p.y(), -p.z());  // mirror in z
    const KabschResult r = estimate_rigid_transform(source, target);
    ASSERT_TRUE(r.valid);
    EXPECT_NEAR(r.T_target_source.linear().determinant(), 1.0, 1e-12);
    EXPECT_TRUE((r.T_target_source.linear().transpose() * r.T_target_source.linear())
                    .isApprox(Eigen::Matrix3d::Identity(), 1e-12));
    EXPECT_GT(r.rms_error_m, 0.1);  // a mirror image cannot be matched rigidly
}

TEST(Kabsch, PlanarPointsAreEnoughButCollinearAreNot) {
    const Eigen::Isometry3d T = make_transform(0.7, 0.0, 0.0, Eigen::Vector3d(1, 0, 0));
    std::vector<Eigen::Vector3d> planar{{0, 0, 0}, {2, 0, 0}, {0, 3, 0}};
    std::vector<Eigen::Vector3d> planar_t;
    for (const auto& p : planar) planar_t.push_back(T * p);
    const KabschResult ok = estimate_rigid_transform(planar, planar_t);
    ASSERT_TRUE(ok.valid);
    EXPECT_TRUE(ok.T_target_source.isApprox(T, 1e-9));

    std::vector<Eigen::Vector3d> line{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {5, 5, 5}};
    std::vector<Eigen::Vector3d> line_t;
    for (const auto& p : line) line_t.push_back(T * p);
    EXPECT_FALSE(estimate_rigid_transform(line, line_t).valid);
    EXPECT_FALSE(estimate_rigid_transform({{0, 0, 0}, {1, 0, 0}}, {{0, 0, 0}, {1, 0, 0}}).valid);
    EXPECT_FALSE(estimate_rigid_transform(planar, line_t).valid);  // size mismatch
}

TEST(Kabsch, CorrespondenceSubset) {
    const Eigen::Isometry3d T = make_transform(1.0, 0.0, 0.0, Eigen::Vector3d(0, 0, 2));
    std::vector<Eigen::Vector3d> source{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {9, 9, 9}};
    std::vector<Eigen::Vector3d> target;
    for (const auto& p : source) target.push_back(T * p);
    target[4] = Eigen::Vector3d(-50, 3, 3);  // an outlier, excluded by the subset
    Correspondences c;
    for (std::uint32_t i = 0; i < 5; ++i) c.push_back({i, i, 0.0f});
    const KabschResult r = estimate_rigid_transform(source, target, c, {0, 1, 2, 3});
    ASSERT_TRUE(r.valid);
    EXPECT_TRUE(r.T_target_source.isApprox(T, 1e-9));
    EXPECT_FALSE(estimate_rigid_transform(source, target, c, {0, 1, 7}).valid);
}

}  // namespace
}  // namespace lidarfuse::core
