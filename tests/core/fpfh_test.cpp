#include "core/features/fpfh.hpp"

#include <gtest/gtest.h>

#include <random>

#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

// A ground plane with a box on it, exact outward normals. The points are jittered by a few
// millimetres so that none sits exactly on the search radius (where a rounding difference
// of the moved copy would decide membership).
PointCloud corner_scene() {
    PointCloud cloud;
    testing::sample_rectangle(Eigen::Vector3d(-6, -6, 0), Eigen::Vector3d(12, 0, 0),
                              Eigen::Vector3d(0, 12, 0), 0.25, Eigen::Vector3d::UnitZ(), &cloud);
    testing::sample_box(Eigen::Vector3d(0.5, 0.5, 0.0), Eigen::Vector3d(3.0, 2.0, 2.0), 0.25,
                        &cloud);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> jitter(-0.003, 0.003);
    for (auto& p : cloud.points) p += Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    return cloud;
}

std::uint32_t nearest_index(const PointCloud& cloud, const Eigen::Vector3d& p) {
    std::uint32_t best = 0;
    for (std::uint32_t i = 1; i < cloud.size(); ++i) {
        if ((cloud.points[i] - p).squaredNorm() < (cloud.points[best] - p).squaredNorm()) best = i;
    }
    return best;
}

TEST(Fpfh, PairFeaturesAreSymmetricAndInvariant) {
    const Eigen::Vector3d p1(0, 0, 0), n1(0, 0, 1), p2(1, 0.3, 0.2);
    const Eigen::Vector3d n2 = Eigen::Vector3d(0.2, 0.1, 1).normalized();
    double a, f, t, a2, f2, t2;
    ASSERT_TRUE(pair_features(p1, n1, p2, n2, &a, &f, &t));
    ASSERT_TRUE(pair_features(p2, n2, p1, n1, &a2, &f2, &t2));
    EXPECT_NEAR(a, a2, 1e-12);
    EXPECT_NEAR(f, f2, 1e-12);
    EXPECT_NEAR(t, t2, 1e-12);
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    ASSERT_TRUE(pair_features(R * p1 + Eigen::Vector3d(5, 5, 5), R * n1,
                              R * p2 + Eigen::Vector3d(5, 5, 5), R * n2, &a2, &f2, &t2));
    EXPECT_NEAR(a, a2, 1e-12);
    EXPECT_NEAR(f, f2, 1e-12);
    EXPECT_NEAR(t, t2, 1e-12);
    EXPECT_FALSE(pair_features(p1, n1, p1, n1, &a, &f, &t));
}

TEST(Fpfh, InvariantUnderRigidTransform) {
    const PointCloud cloud = corner_scene();
    std::vector<std::uint32_t> keypoints;
    for (std::uint32_t i = 0; i < cloud.size(); i += 97) keypoints.push_back(i);
    FpfhParams params;
    params.radius_m = 1.0;
    const auto before = compute_fpfh(cloud, keypoints, params, 2);

    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() =
        Eigen::AngleAxisd(2.3, Eigen::Vector3d(0.1, -0.2, 1).normalized()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(30, -12, 4);
    PointCloud moved;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        moved.points.push_back(T * cloud.points[i]);
        moved.normals.push_back(T.linear() * cloud.normals[i]);
    }
    const auto after = compute_fpfh(moved, keypoints, params);
    ASSERT_EQ(before.size(), after.size());
    for (std::size_t k = 0; k < before.size(); ++k) {
        // Exact geometry moved by floating point: bins can only differ for angles that sit
        // on a bin edge, and the mass moved is tiny.
        EXPECT_LT((before[k] - after[k]).norm(), 1.0f) << "keypoint " << k;
    }
}

TEST(Fpfh, BlocksSumTo100AndCornerDiffersFromPlane) {
    const PointCloud cloud = corner_scene();
    const std::uint32_t plane = nearest_index(cloud, Eigen::Vector3d(-4, -4, 0));
    const std::uint32_t corner = nearest_index(cloud, Eigen::Vector3d(0.5, 0.5, 2.0));
    const std::uint32_t far_plane = nearest_index(cloud, Eigen::Vector3d(-3, 4, 0));
    FpfhParams params;
    params.radius_m = 1.0;
    const auto d = compute_fpfh(cloud, {plane, corner, far_plane}, params);
    for (const FpfhDescriptor& h : d) {
        for (int b = 0; b < 3; ++b) {
            EXPECT_NEAR(h.segment<kFpfhBinsPerAngle>(b * kFpfhBinsPerAngle).sum(), 100.0f, 1e-3f);
        }
        EXPECT_GE(h.minCoeff(), 0.0f);
    }
    // Two plane points look the same; a box corner looks different.
    EXPECT_LT((d[0] - d[2]).norm(), 1.0f);
    EXPECT_GT((d[0] - d[1]).norm(), 30.0f);
    // On a plane with equal normals every pair has alpha = phi = 0 and theta = 0: one bin
    // per block holds everything.
    EXPECT_NEAR(d[0].maxCoeff(), 100.0f, 1e-3f);
}

TEST(Fpfh, MissingNormalsOrIsolatedPointGiveZeros) {
    PointCloud no_normals;
    no_normals.points = {{0, 0, 0}, {0.1, 0, 0}};
    const auto a = compute_fpfh(no_normals, {0, 1});
    ASSERT_EQ(a.size(), 2u);
    EXPECT_EQ(a[0].sum(), 0.0f);
    PointCloud lonely;
    lonely.points = {{0, 0, 0}, {10, 0, 0}};
    lonely.normals = {{0, 0, 1}, {0, 0, 1}};
    const auto b = compute_fpfh(lonely, {0});
    EXPECT_EQ(b[0].sum(), 0.0f);
    EXPECT_EQ(compute_fpfh(lonely, {5})[0].sum(), 0.0f);  // out-of-range keypoint: refused
}

}  // namespace
}  // namespace lidarfuse::core
