#include "core/features/sift_keypoints.hpp"

#include <gtest/gtest.h>

#include <random>

#include "core/preprocess/normals.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

// Distance from p to the nearest edge of the axis-aligned box [lo, lo + size] (edges
// only: the 12 segments).
double distance_to_box_edges(const Eigen::Vector3d& p, const Eigen::Vector3d& lo,
                             const Eigen::Vector3d& size) {
    double best = 1e9;
    for (int axis = 0; axis < 3; ++axis) {
        const int a = (axis + 1) % 3, b = (axis + 2) % 3;
        for (int ca = 0; ca < 2; ++ca) {
            for (int cb = 0; cb < 2; ++cb) {
                Eigen::Vector3d q = lo;
                q[a] += ca * size[a];
                q[b] += cb * size[b];
                q[axis] = std::clamp(p[axis], lo[axis], lo[axis] + size[axis]);
                best = std::min(best, (p - q).norm());
            }
        }
    }
    return best;
}

struct Scene {
    PointCloud cloud;
    std::vector<double> curvature;
};

Scene box_scene(bool with_box) {
    Scene s;
    testing::sample_rectangle(Eigen::Vector3d(-10, -10, 0), Eigen::Vector3d(20, 0, 0),
                              Eigen::Vector3d(0, 20, 0), 0.2, Eigen::Vector3d::UnitZ(), &s.cloud);
    if (with_box) {
        testing::sample_box(Eigen::Vector3d(-1, -1.5, 0), Eigen::Vector3d(3, 2.5, 2), 0.1,
                            &s.cloud);
    }
    // A millimetre of noise, as a scanner has: on an exact lattice most neighbors are tied,
    // and which of them a k-d tree lists first would decide the curvature.
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> jitter(-0.001, 0.001);
    for (auto& p : s.cloud.points) p += Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    s.cloud.normals.clear();
    NormalParams params;
    params.k_neighbors = 12;
    params.compute_covariances = false;
    estimate_normals_covariances(&s.cloud, params, &s.curvature);
    return s;
}

TEST(SiftKeypoints, FindsBoxEdgesAndNothingOnTheGround) {
    const Scene s = box_scene(true);
    SiftKeypointParams params;
    params.min_scale_m = 0.25;
    params.octaves = 2;
    params.min_contrast = 0.005;
    const SiftKeypointResult r = detect_sift_keypoints(s.cloud.points, s.curvature, params, 2);
    ASSERT_GE(r.indices.size(), 4u);
    ASSERT_EQ(r.indices.size(), r.scale_m.size());
    const Eigen::Vector3d lo(-1, -1.5, 0), size(3, 2.5, 2);
    for (std::uint32_t i : r.indices) {
        const Eigen::Vector3d& p = s.cloud.points[i];
        // Every keypoint sits on the box or by a box edge (including the ground-contact
        // edges); none out on the open ground. A face's blob centre is a keypoint too, and
        // every point of the box is within 1.25 m of an edge (half the 2.5 m side).
        EXPECT_LT(distance_to_box_edges(p, lo, size), 1.3) << p.transpose();
    }
}

TEST(SiftKeypoints, FlatPlaneHasNoKeypoints) {
    const Scene s = box_scene(false);
    const SiftKeypointResult r = detect_sift_keypoints(s.cloud.points, s.curvature, {});
    EXPECT_TRUE(r.indices.empty());
}

TEST(SiftKeypoints, DeterministicAcrossThreadCounts) {
    const Scene s = box_scene(true);
    SiftKeypointParams params;
    params.min_scale_m = 0.25;
    const SiftKeypointResult a = detect_sift_keypoints(s.cloud.points, s.curvature, params, 1);
    const SiftKeypointResult b = detect_sift_keypoints(s.cloud.points, s.curvature, params, 2);
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_EQ(a.scale_m, b.scale_m);
}

TEST(SiftKeypoints, BadInput) {
    EXPECT_TRUE(detect_sift_keypoints({}, {}).indices.empty());
    EXPECT_TRUE(detect_sift_keypoints({{0, 0, 0}}, {}).indices.empty());
}

}  // namespace
}  // namespace lidarfuse::core
