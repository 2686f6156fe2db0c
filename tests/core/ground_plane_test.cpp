// Ground plane and levelling on synthetic scans: a tilted sensor over a street with
// buildings, poles and cars finds the road, its height and up direction; clouds without a
// near-horizontal plane report none.
#include "core/initial/ground_plane.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/preprocess/normals.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

// Scans the street scene from `T_world_sensor` and estimates normals (towards the sensor).
PointCloud scan_with_normals(const Eigen::Isometry3d& T_world_sensor, std::uint32_t seed) {
    testing::ScanPattern pattern;
    pattern.range_noise_sigma_m = 0.03;
    PointCloud cloud = testing::scan_scene(testing::street_scene(), T_world_sensor, pattern, seed);
    NormalParams params;
    params.compute_covariances = false;
    estimate_normals_covariances(&cloud, params);
    return cloud;
}

TEST(GroundPlane, FindsTheRoadUnderATiltedSensor) {
    // 6 m pole, looking 17 deg down and rolled 3 deg: up in the sensor frame is not +z.
    const Eigen::Isometry3d T_world_sensor = testing::sensor_pose(-5.0, 8.0, 6.0, 40.0, 17.0, 3.0);
    const PointCloud cloud = scan_with_normals(T_world_sensor, 7);
    const GroundPlane plane = estimate_ground_plane(cloud.points, cloud.normals);
    ASSERT_TRUE(plane.found);
    EXPECT_NEAR(plane.sensor_height_m, 6.0, 0.05);
    const Eigen::Vector3d up_true = T_world_sensor.linear().transpose() * Eigen::Vector3d::UnitZ();
    EXPECT_LT(std::acos(std::min(1.0, plane.up.dot(up_true))) * 180.0 / M_PI, 0.3);
    // The levelled frame puts the road at z = 0 and keeps the sensor's heading.
    const Eigen::Isometry3d T_world_ground = T_world_sensor * plane.T_ground_sensor.inverse();
    EXPECT_NEAR(T_world_ground.translation().z(), 0.0, 0.05);
    EXPECT_NEAR((T_world_ground.linear() * Eigen::Vector3d::UnitZ()).z(), 1.0, 1e-4);
    EXPECT_GT(plane.num_inliers, 1000u);
}

TEST(GroundPlane, NoPlaneWithoutAnUpFacingSurface) {
    // A vertical wall only: every normal is horizontal.
    std::vector<Eigen::Vector3d> points, normals;
    for (int i = 0; i < 40; ++i) {
        for (int k = 0; k < 20; ++k) {
            points.emplace_back(10.0, -10.0 + 0.5 * i, -3.0 + 0.3 * k);
            normals.emplace_back(-1.0, 0.0, 0.0);
        }
    }
    EXPECT_FALSE(estimate_ground_plane(points, normals).found);
    EXPECT_FALSE(estimate_ground_plane({}, {}).found);
    // Mismatched sizes.
    EXPECT_FALSE(estimate_ground_plane(points, {}).found);
}

TEST(GroundPlane, UpsideDownSensorHasNoGround) {
    // Mounted upside down, the road is "above": outside max_tilt_deg of +z.
    const Eigen::Isometry3d T_world_sensor = testing::sensor_pose(0.0, 0.0, 6.0, 0.0, 0.0, 180.0);
    const PointCloud cloud = scan_with_normals(T_world_sensor, 3);
    EXPECT_FALSE(estimate_ground_plane(cloud.points, cloud.normals).found);
}

}  // namespace
}  // namespace lidarfuse::core
