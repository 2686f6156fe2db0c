#include "core/preprocess/octree_downsample.hpp"

#include <gtest/gtest.h>

#include <random>

#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

TEST(NormalVoting, PicksTheDominantAxisAndFoldsSigns) {
    NormalVoting voting(10.0, 20.0);
    EXPECT_GT(voting.cell_count(), 100);
    std::mt19937 rng(1);
    std::normal_distribution<double> jitter(0.0, 0.05);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.8, 0.2).normalized();
    std::vector<Eigen::Vector3d> normals;
    for (int i = 0; i < 70; ++i) {
        Eigen::Vector3d n =
            (axis + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng))).normalized();
        normals.push_back(i % 2 ? n : Eigen::Vector3d(-n));  // both signs: folded together
    }
    for (int i = 0; i < 30; ++i)
        normals.push_back(Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized());
    std::vector<std::uint32_t> idx(normals.size());
    for (std::uint32_t i = 0; i < idx.size(); ++i) idx[i] = i;
    const NormalVoting::Vote vote = voting.dominant(normals, idx.data(), idx.size());
    EXPECT_GT(std::abs(vote.direction.dot(axis)), std::cos(3.0 * M_PI / 180.0));
    EXPECT_NEAR(vote.direction.norm(), 1.0, 1e-12);
    EXPECT_GE(vote.agreeing_share, 0.7);
    EXPECT_LT(vote.agreeing_share, 0.85);
    // Equator: a normal and its opposite (both z = 0) land in neighboring cells.
    const Eigen::Vector3d e(1, 0, 0);
    std::vector<Eigen::Vector3d> equator{e, -e, e, -e};
    std::vector<std::uint32_t> four{0, 1, 2, 3};
    const NormalVoting::Vote eq = voting.dominant(equator, four.data(), 4);
    EXPECT_NEAR(std::abs(eq.direction.dot(e)), 1.0, 1e-9);
    EXPECT_DOUBLE_EQ(eq.agreeing_share, 1.0);
}

TEST(OctreeDownsample, PlaneStaysCoarse) {
    PointCloud plane;
    testing::sample_rectangle(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(16, 0, 0),
                              Eigen::Vector3d(0, 16, 0), 0.1, Eigen::Vector3d::UnitZ(), &plane);
    OctreeDownsampleParams params;
    params.max_voxel_size_m = 2.0;
    params.min_voxel_size_m = 0.25;
    const OctreeDownsampleResult r = octree_downsample(plane, {}, params);
    // 16 m x 16 m at 2 m: about 64 voxels (the bounding box adds at most one more row).
    EXPECT_LE(r.cloud.size(), 81u);
    EXPECT_GE(r.cloud.size(), 64u);
    for (std::size_t i = 0; i < r.cloud.size(); ++i) {
        EXPECT_FLOAT_EQ(r.voxel_size_m[i], 2.0f);
        EXPECT_NEAR(r.cloud.normals[i].z(), 1.0, 1e-9);
        EXPECT_NEAR(r.cloud.points[i].z(), 0.0, 1e-9);
    }
}

TEST(OctreeDownsample, DetailGetsFineVoxelsAndNormalsAreUnit) {
    PointCloud cloud;
    testing::sample_rectangle(Eigen::Vector3d(-8, -8, 0), Eigen::Vector3d(16, 0, 0),
                              Eigen::Vector3d(0, 16, 0), 0.1, Eigen::Vector3d::UnitZ(), &cloud);
    // A small box: its edges and corners have normals that disagree.
    testing::sample_box(Eigen::Vector3d(0.3, 0.3, 0.0), Eigen::Vector3d(1.0, 1.4, 1.2), 0.05,
                        &cloud);
    std::vector<double> curvature(cloud.size(), 0.01);
    OctreeDownsampleParams params;
    params.max_voxel_size_m = 2.0;
    params.min_voxel_size_m = 0.25;
    const OctreeDownsampleResult r = octree_downsample(cloud, curvature, params);
    ASSERT_FALSE(r.cloud.empty());
    ASSERT_EQ(r.cloud.normals.size(), r.cloud.size());
    ASSERT_EQ(r.curvature.size(), r.cloud.size());
    std::size_t fine_near_box = 0, coarse_far = 0, fine_far = 0;
    std::uint32_t total = 0;
    for (std::size_t i = 0; i < r.cloud.size(); ++i) {
        EXPECT_NEAR(r.cloud.normals[i].norm(), 1.0, 1e-9);
        EXPECT_NEAR(r.curvature[i], 0.01, 1e-12);
        total += r.point_count[i];
        const Eigen::Vector3d& p = r.cloud.points[i];
        const bool near_box = p.x() > -0.5 && p.x() < 2.5 && p.y() > -0.5 && p.y() < 2.5;
        if (near_box && r.voxel_size_m[i] <= 0.25f) ++fine_near_box;
        if (!near_box && p.norm() > 5.0) {
            if (r.voxel_size_m[i] == 2.0f)
                ++coarse_far;
            else
                ++fine_far;
        }
    }
    EXPECT_EQ(total, cloud.size());  // every point is in exactly one leaf
    EXPECT_GT(fine_near_box, 20u);
    EXPECT_GT(coarse_far, 20u);
    EXPECT_EQ(fine_far, 0u);
    // Finest voxel: 2 m / 2^3.
    float finest = 10.0f;
    for (float s : r.voxel_size_m) finest = std::min(finest, s);
    EXPECT_FLOAT_EQ(finest, 0.25f);
}

TEST(OctreeDownsample, OrientationFollowsTheMajority) {
    PointCloud plane;
    testing::sample_rectangle(Eigen::Vector3d(0.1, 0.1, 0.5), Eigen::Vector3d(1.5, 0, 0),
                              Eigen::Vector3d(0, 1.5, 0), 0.1, -Eigen::Vector3d::UnitZ(), &plane);
    for (std::size_t i = 0; i < plane.size(); i += 4) plane.normals[i] = Eigen::Vector3d::UnitZ();
    OctreeDownsampleParams params;
    params.max_voxel_size_m = 2.0;
    const OctreeDownsampleResult r = octree_downsample(plane, {}, params);
    ASSERT_EQ(r.cloud.size(), 1u);
    EXPECT_NEAR(r.cloud.normals[0].z(), -1.0, 1e-9);
    EXPECT_TRUE(r.curvature.empty());
}

TEST(OctreeDownsample, EmptyAndInvalidInput) {
    EXPECT_TRUE(octree_downsample(PointCloud{}).cloud.empty());
    PointCloud no_normals;
    no_normals.points = {{0, 0, 0}};
    EXPECT_TRUE(octree_downsample(no_normals).cloud.empty());
    PointCloud nan_cloud;
    nan_cloud.points = {{NAN, 0, 0}, {1, 1, 1}};
    nan_cloud.normals = {{0, 0, 1}, {0, 0, 1}};
    const OctreeDownsampleResult r = octree_downsample(nan_cloud);
    ASSERT_EQ(r.cloud.size(), 1u);
    EXPECT_EQ(r.cloud.points[0], Eigen::Vector3d(1, 1, 1));
}

}  // namespace
}  // namespace lidarfuse::core
