// FusionEngine::process with FrameMode::kPredict: a frame fused at each sensor's pose
// predicted from its registered frames (see fusion_engine.hpp), for a caller that is behind.
// How the poses are predicted and when they are trusted: SensorTrack::predict_unregistered,
// FusionParams::prediction_*; measured against the simulator's truth in bench/BENCHMARK.md
// ("How far ahead a pose can be predicted", "Frames fused at predicted poses").
#include <algorithm>

#include "core/pipeline/fusion_engine_impl.hpp"

namespace lidarfuse::core {

// A frame can be predicted when registering it would do nothing that cannot wait (no
// initial registration waits to be applied, no sensor to register again) and every tracked
// sensor with a scan in it has a pose it can trust for its time
// (SensorTrack::predict_unregistered: enough recent registered poses, within reach, and a
// fit that its last registered frames confirmed). On a machine so busy that registered
// frames lie further apart, the frame is registered (or dropped) instead. A tracked sensor
// without a scan keeps its last pose, as in a registered frame.
std::optional<std::vector<Eigen::Isometry3d>> FusionEngine::Impl::predicted_poses(
    const FrameInput& in) const {
    if (in.sensors.size() != n || !tracks[params.root_sensor]->initialised()) return std::nullopt;
    if (pending && pending->job->done()) return std::nullopt;
    if (last_registered_health.size() != n) return std::nullopt;
    std::vector<Eigen::Isometry3d> poses(n, Eigen::Isometry3d::Identity());
    for (std::size_t s = 0; s < n; ++s) {
        if (needs_reinit[s]) return std::nullopt;
        if (!tracks[s]->initialised()) continue;
        const SensorScanInput& scan = in.sensors[s];
        if (!usable(scan)) {
            poses[s] = tracks[s]->predict(scan.t_ns);
            continue;
        }
        const std::optional<Eigen::Isometry3d> pose = tracks[s]->predict_unregistered(scan.t_ns);
        if (!pose) return std::nullopt;
        poses[s] = *pose;
    }
    return poses;
}

// Each tracked sensor with a scan: its points deskewed, cropped and flagged (the background
// model sees every frame, as in a registered one), placed at its predicted pose.
FrameOutput FusionEngine::Impl::process_predicted(const FrameInput& in,
                                                  std::vector<Eigen::Isometry3d> poses) {
    const Stopwatch frame_time;
    FrameWork w = begin_frame(in, false);
    const Stopwatch prep_time;
    w.predicted = std::move(poses);
    for (std::size_t s = 0; s < n; ++s) {
        if (tracks[s]->initialised() && w.usable[s]) w.active.push_back(s);
    }
    const int threads = std::max(1, params.num_threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t k = 0; k < w.active.size(); ++k) {
        const std::size_t s = w.active[k];
        tracks[s]->prepare_points(in.sensors[s], w.predicted[s], thread_scratch());
    }
    w.out.timings.preprocess_ms = prep_time.milliseconds();
    w.out.initial_registration_pending = pending.has_value();
    report_predicted_poses(&w);
    build_fused_cloud(&w);
    w.out.timings.total_ms = frame_time.milliseconds();
    return std::move(w.out);
}

// Poses as predicted; the registration figures (fitness, inliers, conditioning, residual)
// of the last registered frame, as nothing was measured in this one.
void FusionEngine::Impl::report_predicted_poses(FrameWork* w) const {
    FrameOutput& out = w->out;
    for (std::size_t s = 0; s < n; ++s) {
        SensorHealth& h = out.health[s];
        const SensorTrack& track = *tracks[s];
        if (!track.initialised()) {
            h.state = TrackState::kUninitialised;
            continue;
        }
        const SensorHealth& last = last_registered_health[s];
        h.fitness_previous = last.fitness_previous;
        h.fitness_reference = last.fitness_reference;
        h.inliers_reference = last.inliers_reference;
        h.min_hessian_eigenvalue = last.min_hessian_eigenvalue;
        h.max_edge_residual_sigma = last.max_edge_residual_sigma;
        h.registration_points = last.registration_points;
        h.pose_valid = true;
        out.T_root_sensor[s] = w->predicted[s];
        h.state = w->usable[s] ? TrackState::kPredicted : TrackState::kMissing;
        if (!w->usable[s]) continue;
        h.static_points = track.current_points().size() - track.current_dynamic_count();
        h.dynamic_points = track.current_dynamic_count();
    }
}

}  // namespace lidarfuse::core
