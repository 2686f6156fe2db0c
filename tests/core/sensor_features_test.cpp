#include "core/features/sensor_features.hpp"

#include <gtest/gtest.h>

#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

PointCloud street_scan(std::size_t sensor) {
    testing::ScanPattern pattern;
    pattern.columns = 512;
    pattern.range_noise_sigma_m = 0.03;
    return testing::scan_scene(testing::street_scene(), testing::street_sensor_poses()[sensor],
                               pattern, 100 + static_cast<std::uint32_t>(sensor));
}

TEST(SensorFeatures, StreetScanGivesKeypointsAndDescriptors) {
    const PointCloud cloud = street_scan(0);
    SensorFeatureParams params;
    const SensorFeatures f = compute_sensor_features(cloud, params, 8, 2);
    ASSERT_EQ(f.status, SensorFeatureStatus::kOk) << to_string(f.status);
    EXPECT_EQ(f.num_input_points, cloud.size());
    EXPECT_LE(f.num_preprocessed_points, cloud.size());
    EXPECT_GT(f.num_preprocessed_points, cloud.size() * 9 / 10);
    EXPECT_LT(f.octree.cloud.size(), f.num_preprocessed_points / 4);
    EXPECT_GT(f.keypoints.size(), 30u);
    EXPECT_EQ(f.descriptors.size(), f.keypoints.size());
    EXPECT_EQ(f.keypoint_points.size(), f.keypoints.size());
    for (std::size_t k = 0; k < f.keypoints.size(); ++k) {
        EXPECT_EQ(f.keypoint_points[k], f.octree.cloud.points[f.keypoints[k]]);
    }
    EXPECT_TRUE(f.gicp.has_plane_covariances());
    EXPECT_GT(f.normal_spread, params.min_normal_spread);
    // Deterministic, whatever the thread count.
    const SensorFeatures again = compute_sensor_features(cloud, params, 8, 1);
    EXPECT_EQ(again.keypoints, f.keypoints);
    ASSERT_EQ(again.descriptors.size(), f.descriptors.size());
    for (std::size_t k = 0; k < f.descriptors.size(); ++k) {
        EXPECT_EQ(again.descriptors[k], f.descriptors[k]);
    }
}

TEST(SensorFeatures, PlaneOnlyAndEmpty) {
    testing::Scene flat;
    testing::ScanPattern pattern;
    pattern.columns = 512;
    const PointCloud plane =
        testing::scan_scene(flat, testing::sensor_pose(0, 0, 6, 0, 10), pattern, 3);
    ASSERT_GT(plane.size(), 1000u);
    const SensorFeatures f = compute_sensor_features(plane, {});
    EXPECT_TRUE(f.status == SensorFeatureStatus::kPlaneOnly ||
                f.status == SensorFeatureStatus::kTooFewKeypoints)
        << to_string(f.status);
    EXPECT_TRUE(f.descriptors.empty() || f.status == SensorFeatureStatus::kTooFewKeypoints);

    EXPECT_EQ(compute_sensor_features(PointCloud{}, {}).status, SensorFeatureStatus::kEmptyCloud);
    PointCloud few;
    few.points = {{5, 0, 0}, {5, 1, 0}, {5, 0, 1}};
    EXPECT_EQ(compute_sensor_features(few, {}).status, SensorFeatureStatus::kEmptyCloud);
    // Everything inside the minimum range (e.g. the sensor housing): nothing left.
    PointCloud close;
    for (int i = 0; i < 100; ++i) close.points.emplace_back(0.1, 0.001 * i, 0.0);
    EXPECT_EQ(compute_sensor_features(close, {}).status, SensorFeatureStatus::kEmptyCloud);
}

}  // namespace
}  // namespace lidarfuse::core
