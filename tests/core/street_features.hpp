#pragma once
// Features of one sensor of the synthetic street (tests/core/synthetic_lidar_scene.hpp):
// 512 columns to stay fast under sanitizers, 3 cm range noise, a fixed seed per sensor.
// Shared by the pair-level registration tests.

#include <cstdint>

#include "core/features/sensor_features.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::testing {

inline core::SensorFeatures street_features(std::size_t sensor) {
    ScanPattern pattern;
    pattern.columns = 512;
    pattern.range_noise_sigma_m = 0.03;
    const core::PointCloud cloud = scan_scene(street_scene(), street_sensor_poses()[sensor],
                                              pattern, 100 + static_cast<std::uint32_t>(sensor));
    return core::compute_sensor_features(cloud, {});
}

}  // namespace lidarfuse::testing
