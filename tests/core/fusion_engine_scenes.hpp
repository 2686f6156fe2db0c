#pragma once
// What the FusionEngine tests share (fusion_engine_test.cpp, frame_prediction_test.cpp):
// three of the synthetic street's sensors at 20 Hz, the engine's parameters for them, and
// the fast sway, whose scans are cast column by column from the pose of each column's
// instant (ground truth exact at every scan time).
#include <cmath>
#include <cstdint>
#include <random>

#include "core/common/se3.hpp"
#include "core/pipeline/fusion_engine.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core::engine_scenes {

constexpr int kSensors = 3;
constexpr double kFramePeriodS = 0.05;

struct Errors {
    double trans_m = 0, rot_deg = 0;
};

inline FusionParams test_params() {
    FusionParams p;
    p.voxel_size_m = 0.5;
    p.window_frames = 5;
    p.num_threads = 2;
    p.initial_registration_inline = true;
    return p;
}

// The fast sway: poles swaying fast (~0.45 m/s, ~4 deg/s) and every column cast from the
// pose of its own instant, as a spinning sensor measures.
inline Eigen::Isometry3d fast_pose(int sensor, double t) {
    static const int kPick[kSensors] = {0, 2, 3};
    const auto nominal = testing::street_sensor_poses()[static_cast<std::size_t>(kPick[sensor])];
    Eigen::Isometry3d sway = Eigen::Isometry3d::Identity();
    sway.translation() = Eigen::Vector3d(0.15 * std::sin(3.0 * t + sensor),
                                         0.1 * std::cos(2.5 * t + 2 * sensor), 0.0);
    sway.linear() =
        (Eigen::AngleAxisd(0.03 * std::sin(2.5 * t + sensor), Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(0.02 * std::cos(2.2 * t + sensor), Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
    return nominal * sway;
}

// One sweep starting at t0_s: column c fires at t0_s + c * period / columns from the pose of
// that instant; points in the sensor frame of that instant, with their time offsets.
inline SensorScanInput moving_scan(const testing::Scene& scene, int sensor, double t0_s,
                                   std::uint32_t seed) {
    testing::ScanPattern pattern;
    pattern.columns = 512;
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, pattern.range_noise_sigma_m);
    SensorScanInput scan;
    scan.present = true;
    scan.t_ns = static_cast<std::int64_t>(std::llround(t0_s * 1e9));
    const double d = M_PI / 180.0;
    for (int c = 0; c < pattern.columns; ++c) {
        const double dt = kFramePeriodS * c / pattern.columns;
        const Eigen::Isometry3d T = fast_pose(sensor, t0_s + dt);
        const double az = 2.0 * M_PI * c / pattern.columns;
        for (int b = 0; b < pattern.beams; ++b) {
            const double el = (pattern.min_elevation_deg +
                               (pattern.max_elevation_deg - pattern.min_elevation_deg) * b /
                                   (pattern.beams - 1)) *
                              d;
            const Eigen::Vector3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                      std::sin(el));
            const double hit = testing::cast_ray(scene, T.translation(), T.linear() * dir);
            const double range = hit + noise(rng);
            if (!std::isfinite(hit) || hit > pattern.max_range_m || range < pattern.min_range_m)
                continue;
            scan.points.push_back((range * dir).cast<float>());
            scan.point_dt_s.push_back(static_cast<float>(dt));
        }
    }
    return scan;
}

// Sensor s's scan time in frame f of the fast sway (s), the sensors 11 ms apart.
inline double fast_sway_time_s(int f, int s) { return 1.0 + f * kFramePeriodS + s * 0.011; }

// Frame f of the fast sway: every sensor's sweep.
inline FrameInput fast_sway_frame(const testing::Scene& scene, int f) {
    FrameInput in;
    for (int s = 0; s < kSensors; ++s) {
        in.sensors.push_back(moving_scan(scene, s, fast_sway_time_s(f, s),
                                         static_cast<std::uint32_t>(1000 * f + s)));
    }
    return in;
}

// Sensor s's true pose at its scan of frame f, relative to the root at the first frame.
inline Eigen::Isometry3d fast_sway_truth(int f, int s) {
    return fast_pose(0, fast_sway_time_s(0, 0)).inverse() * fast_pose(s, fast_sway_time_s(f, s));
}

}  // namespace lidarfuse::core::engine_scenes
