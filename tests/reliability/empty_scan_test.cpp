// Row "empty or all-invalid scans": a sensor whose scans arrive but hold no point (lens
// covered, all returns invalid, every pixel below min range) is skipped for those frames;
// the other sensors keep being fused and tracked, and nothing stalls or throws.
// FusionEngine is driven directly, as lidarfused's fusion thread drives it, on the
// synthetic street of tests/core (ground truth known).
#include <gtest/gtest.h>

#include <cmath>

#include "core/pipeline/fusion_engine.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::reliability {
namespace {

constexpr int kSensors = 3;

Eigen::Isometry3d pose(int sensor) {
    static const int kPick[kSensors] = {0, 2, 3};
    return lidarfuse::testing::street_sensor_poses()[static_cast<std::size_t>(kPick[sensor])];
}

core::FrameInput frame(int f, bool sensor2_empty) {
    lidarfuse::testing::ScanPattern pattern;
    pattern.columns = 512;
    const auto scene = lidarfuse::testing::street_scene();
    core::FrameInput in;
    in.sensors.resize(kSensors);
    for (int s = 0; s < kSensors; ++s) {
        auto& scan = in.sensors[static_cast<std::size_t>(s)];
        scan.present = true;  // the scan arrived ...
        scan.t_ns = 1'000'000'000LL + f * 50'000'000LL + s * 1'000'000LL;
        if (s == 2 && sensor2_empty) continue;  // ... but without a single valid point
        core::cast_points(lidarfuse::testing::scan_scene(scene, pose(s), pattern,
                                                         static_cast<std::uint32_t>(1000 * f + s))
                              .points,
                          &scan.points);
    }
    return in;
}

TEST(EmptyScans, AnEmptySensorIsSkippedWhileTheOthersKeepTracking) {
    core::FusionParams params;
    params.voxel_size_m = 0.5;
    params.window_frames = 5;
    params.num_threads = 2;
    params.initial_registration_inline = true;
    core::FusionEngine engine(kSensors, params);
    for (int f = 0; f < 12; ++f) {
        const bool empty = f >= 4 && f < 8;
        core::FrameOutput out;
        ASSERT_NO_THROW(out = engine.process(frame(f, empty))) << "frame " << f;
        ASSERT_EQ(out.health.size(), static_cast<std::size_t>(kSensors));
        if (empty) {
            EXPECT_EQ(out.health[2].registration_points, 0u) << "frame " << f;
            EXPECT_FALSE(out.health[2].included &&
                         out.health[2].state == core::TrackState::kTracking &&
                         out.health[2].fitness_previous > 0.0)
                << "frame " << f << ": an empty scan was registered";
            // Skipped like a missing scan, and said so; the pose is the prediction.
            EXPECT_FALSE(out.health[2].included) << "frame " << f;
            EXPECT_TRUE(out.health[2].pose_valid) << "frame " << f;
            EXPECT_NE(out.health[2].event.find("skipped"), std::string::npos) << "frame " << f;
        }
        // The root and the other sensor are fused every frame, at their true poses.
        for (int s = 0; s < 2; ++s) {
            EXPECT_TRUE(out.health[static_cast<std::size_t>(s)].pose_valid)
                << "sensor " << s << " frame " << f;
            const Eigen::Isometry3d truth = pose(0).inverse() * pose(s);
            const double err =
                (out.T_root_sensor[static_cast<std::size_t>(s)].translation() - truth.translation())
                    .norm();
            EXPECT_LT(err, 0.05) << "sensor " << s << " frame " << f;
        }
        EXPECT_GT(out.cloud.points.size(), 0u) << "frame " << f;
        if (f >= 10) {  // points again: tracked again, at its true pose
            EXPECT_TRUE(out.health[2].pose_valid) << "frame " << f;
            const Eigen::Isometry3d truth = pose(0).inverse() * pose(2);
            EXPECT_LT((out.T_root_sensor[2].translation() - truth.translation()).norm(), 0.05)
                << "frame " << f;
        }
    }
}

}  // namespace
}  // namespace lidarfuse::reliability
