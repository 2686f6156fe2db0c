#include "core/registration/p2p_error.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace lidarfuse::core {
namespace {

TEST(P2pError, HandComputedValue) {
    const std::vector<Eigen::Vector3d> target = {{0, 0, 0}, {10, 0, 0}};
    const KdTree tree(target);
    // Distances to the nearest target point: 0.3, 0.4, 2.0 (beyond r_c = 1), 0.0.
    const std::vector<Eigen::Vector3d> source = {{0.3, 0, 0}, {10, 0.4, 0}, {5, 0, 0}, {0, 0, 0}};
    const P2pErrorResult r = p2p_error(source, tree, Eigen::Isometry3d::Identity(), {1.0}, 1);
    ASSERT_TRUE(r.valid);
    EXPECT_EQ(r.num_within_cutoff, 3u);
    EXPECT_EQ(r.num_source, 4u);
    EXPECT_DOUBLE_EQ(r.overlap_share, 0.75);
    EXPECT_NEAR(r.error_m, std::sqrt((0.09 + 0.16 + 0.0) / 3.0), 1e-12);
}

TEST(P2pError, TransformIsAppliedToTheSource) {
    const std::vector<Eigen::Vector3d> target = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const KdTree tree(target);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0, 0, 1);
    const std::vector<Eigen::Vector3d> source = {{1, 0, -1}, {0, 1, -1}, {0, 0, 0}};
    const P2pErrorResult r = p2p_error(source, tree, T, {0.5}, 2);
    EXPECT_EQ(r.num_within_cutoff, 3u);
    EXPECT_NEAR(r.error_m, 0.0, 1e-15);
    // Identity instead: every point is 1 m off -> none within 0.5 m.
    const P2pErrorResult none = p2p_error(source, tree, Eigen::Isometry3d::Identity(), {0.5}, 2);
    EXPECT_FALSE(none.valid);
    EXPECT_EQ(none.num_within_cutoff, 0u);
    EXPECT_EQ(none.overlap_share, 0.0);
}

TEST(P2pError, ThreadCountAgreesAndEmptyInputs) {
    std::mt19937 rng(8);
    std::uniform_real_distribution<double> u(0.0, 10.0);
    std::vector<Eigen::Vector3d> a(3000), b(3000);
    for (auto& p : a) p = {u(rng), u(rng), u(rng)};
    for (auto& p : b) p = {u(rng), u(rng), u(rng)};
    const KdTree tree(a);
    const P2pErrorResult r1 = p2p_error(b, tree, Eigen::Isometry3d::Identity(), {0.5}, 1);
    const P2pErrorResult r2 = p2p_error(b, tree, Eigen::Isometry3d::Identity(), {0.5}, 2);
    EXPECT_EQ(r1.num_within_cutoff, r2.num_within_cutoff);
    EXPECT_NEAR(r1.error_m, r2.error_m, 1e-12);
    EXPECT_GT(r1.num_within_cutoff, 0u);
    EXPECT_LE(r1.error_m, 0.5);

    const std::vector<Eigen::Vector3d> empty;
    const KdTree empty_tree(empty);
    EXPECT_FALSE(p2p_error(b, empty_tree, Eigen::Isometry3d::Identity()).valid);
    const P2pErrorResult e = p2p_error(empty, tree, Eigen::Isometry3d::Identity());
    EXPECT_FALSE(e.valid);
    EXPECT_EQ(e.overlap_share, 0.0);
}

}  // namespace
}  // namespace lidarfuse::core
