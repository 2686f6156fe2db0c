#include "core/pipeline/sensor_track.hpp"

#include <gtest/gtest.h>

#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

const Eigen::Isometry3d kSensorPose = testing::sensor_pose(0.0, 0.0, 5.0, 0.0, 10.0);

SensorScanInput scan_of(const testing::Scene& scene, std::uint32_t seed, std::int64_t t_ns) {
    testing::ScanPattern pattern;
    pattern.beams = 32;
    pattern.columns = 360;
    SensorScanInput scan;
    scan.present = true;
    scan.t_ns = t_ns;
    cast_points(testing::scan_scene(scene, kSensorPose, pattern, seed).points, &scan.points);
    return scan;
}

// The street with a van parked in view, which then leaves.
testing::Scene street_with_van() {
    testing::Scene scene = testing::street_scene();
    scene.boxes.push_back(
        testing::SceneBox(Eigen::Vector3d(9.0, 1.0, 0.0), Eigen::Vector3d(5.0, 2.2, 2.6), 0.1));
    return scene;
}

FusionParams track_params() {
    FusionParams params;
    params.deskew = false;  // static sensor: no motion to undo
    return params;
}

// A track that diverged is reset and started again on a new reference scan: the new
// reference target must be the one a fresh track builds on that scan. The background
// model's flags of the old reference (the van's points, removed since its frame) index
// points of the old scan and must not thin the new one.
TEST(SensorTrack, RestartedTrackForgetsTheOldReferencesDynamicPoints) {
    const FusionParams params = track_params();
    SensorTrack track(params);
    TrackScratch scratch;
    const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    track.start(0, scan_of(street_with_van(), 1, 0), T, &scratch);
    const testing::Scene empty_street = testing::street_scene();
    for (int f = 1; f <= 6; ++f) {
        track.prepare(scan_of(empty_street, 1 + f, f * 50'000'000LL), T, &scratch);
        track.finish_frame(f, f * 50'000'000LL, T);
    }
    // The van's points were found gone from the reference, and the reference rebuilt without
    // them: the flags this test is about are set.
    SensorTrack fresh(params);
    fresh.start(0, scan_of(street_with_van(), 1, 0), T, &scratch);
    ASSERT_LT(track.reference_target().size(), fresh.reference_target().size());

    track.reset();
    const SensorScanInput restart = scan_of(street_with_van(), 20, 400'000'000LL);
    track.start(8, restart, T, &scratch);
    SensorTrack restarted_fresh(params);
    restarted_fresh.start(8, restart, T, &scratch);
    const auto& got = track.reference_target().points();
    const auto& want = restarted_fresh.reference_target().points();
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i], want[i]) << "point " << i;
}

// The engine keeps one scratch per thread for all the tracks that thread prepares: a track
// must flag and downsample a scan the same after another sensor's scan went through that
// scratch as with a scratch of its own. Here one track's van leaves while the other's
// arrives, so their reference and current images differ wherever the flags come from.
TEST(SensorTrack, TracksSharingOneScratchPrepareAsWithTheirOwn) {
    const FusionParams params = track_params();
    const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    const testing::Scene empty_street = testing::street_scene();
    SensorTrack leaving(params), arriving(params), leaving_alone(params), arriving_alone(params);
    TrackScratch shared, leaving_own, arriving_own;
    const SensorScanInput first_leaving = scan_of(street_with_van(), 1, 0);
    const SensorScanInput first_arriving = scan_of(empty_street, 2, 0);
    leaving.start(0, first_leaving, T, &shared);
    arriving.start(0, first_arriving, T, &shared);
    leaving_alone.start(0, first_leaving, T, &leaving_own);
    arriving_alone.start(0, first_arriving, T, &arriving_own);
    for (int f = 1; f <= 4; ++f) {
        const std::int64_t t = f * 50'000'000LL;
        const SensorScanInput to_leaving = scan_of(empty_street, 10 + f, t);
        const SensorScanInput to_arriving = scan_of(street_with_van(), 20 + f, t);
        leaving.prepare(to_leaving, T, &shared);
        arriving.prepare(to_arriving, T, &shared);
        leaving_alone.prepare(to_leaving, T, &leaving_own);
        arriving_alone.prepare(to_arriving, T, &arriving_own);
        ASSERT_GT(arriving.current_dynamic_count(), 0u) << "frame " << f;
        EXPECT_EQ(leaving.current_dynamic(), leaving_alone.current_dynamic()) << "frame " << f;
        EXPECT_EQ(arriving.current_dynamic(), arriving_alone.current_dynamic()) << "frame " << f;
        EXPECT_EQ(leaving.current_target().points(), leaving_alone.current_target().points());
        EXPECT_EQ(arriving.current_target().points(), arriving_alone.current_target().points());
        EXPECT_EQ(leaving.reference_target().points(), leaving_alone.reference_target().points());
        for (SensorTrack* track : {&leaving, &arriving, &leaving_alone, &arriving_alone})
            track->finish_frame(f, t, T);
    }
}

// The fine edges take a track's reference target instead of building it again where it is
// that very cloud: then it must be exactly what reference_target_at() builds at that moment,
// and it is offered after a start and after a rebuild, and not after anything that changes
// the reference's points, flags or pose (the grid lies in the root frame).
TEST(SensorTrack, ReferenceTargetIsOfferedOnlyWhileItIsWhatWouldBeBuilt) {
    const FusionParams params = track_params();
    const double voxel = params.reference_target_voxel_size_m;
    ASSERT_LT(voxel, params.voxel_size_m) << "a reference target of its own voxel size";
    SensorTrack track(params);
    TrackScratch scratch;
    const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    const auto offered_is_built = [&](const char* when) {
        const GicpCloud* offered = track.reference_target_if_built_at(voxel);
        if (offered) {
            EXPECT_EQ(offered->points(), track.reference_target_at(voxel).points()) << when;
        }
        return offered != nullptr;
    };
    track.start(0, scan_of(street_with_van(), 1, 0), T, &scratch);
    EXPECT_TRUE(offered_is_built("after the start"));
    EXPECT_EQ(track.reference_target_if_built_at(params.voxel_size_m), nullptr);
    track.set_reference_pose(T);  // the same pose: nothing changed
    EXPECT_TRUE(offered_is_built("after the same pose"));

    // The van leaves: the background model flags its reference points, and once they are
    // enough the reference target is rebuilt without them (and offered again).
    const testing::Scene empty_street = testing::street_scene();
    int offered_after_prepare = 0;
    for (int f = 1; f <= 6; ++f) {
        track.prepare(scan_of(empty_street, 1 + f, f * 50'000'000LL), T, &scratch);
        offered_after_prepare += offered_is_built("after a prepare");
        track.finish_frame(f, f * 50'000'000LL, T);
    }
    EXPECT_GE(offered_after_prepare, 1) << "the rebuild after the van left";
    EXPECT_LT(offered_after_prepare, 6) << "flags changed without a rebuild";

    track.start(7, scan_of(street_with_van(), 9, 350'000'000LL), T, &scratch);
    ASSERT_TRUE(offered_is_built("after a restart"));
    Eigen::Isometry3d moved = T;
    moved.translation() = Eigen::Vector3d(0.13, -0.07, 0.02);
    track.set_reference_pose(moved);
    EXPECT_FALSE(offered_is_built("after the pose moved"));
    EXPECT_NE(track.reference_target().points(), track.reference_target_at(voxel).points())
        << "the pose decides the grid, so the target it would build now differs";

    track.start(8, scan_of(street_with_van(), 10, 400'000'000LL), T, &scratch);
    ASSERT_TRUE(offered_is_built("after another restart"));
    track.reanchor(moved, Eigen::Isometry3d::Identity());
    EXPECT_FALSE(offered_is_built("after a re-anchoring"));
    track.reset();
    EXPECT_FALSE(offered_is_built("after a reset"));
}

}  // namespace
}  // namespace lidarfuse::core
