#include "core/pipeline/fusion_engine.hpp"

#include <omp.h>

#include <algorithm>
#include <utility>

#include "core/pipeline/fusion_engine_impl.hpp"

namespace lidarfuse::core {

const char* to_string(TrackState state) {
    switch (state) {
        case TrackState::kUninitialised:
            return "uninitialised";
        case TrackState::kTracking:
            return "tracking";
        case TrackState::kMissing:
            return "missing";
        case TrackState::kReinitialised:
            return "reinitialised";
        case TrackState::kPredicted:
            return "predicted";
    }
    return "unknown";
}

namespace {

PoseGraphParams graph_params(const FusionParams& p) {
    PoseGraphParams g;
    g.huber_delta = p.huber_delta;
    g.max_iterations = p.graph_max_iterations;
    return g;
}

}  // namespace

FusionEngine::Impl::Impl(std::size_t num_sensors, const FusionParams& p)
    : shared_params(std::make_shared<const FusionParams>(p)),
      params(*shared_params),
      n(num_sensors),
      graph(graph_params(p)),
      suspicious(num_sensors, 0),
      needs_reinit(num_sensors, false),
      window(&graph, p.window_frames),
      started_first(num_sensors, false),
      reanchored_frame(num_sensors, -1) {
    for (std::size_t i = 0; i < n; ++i) tracks.push_back(std::make_unique<SensorTrack>(params));
    GicpParams g = params.gicp;
    g.max_correspondence_distance_m = params.correspondence_factor * params.voxel_size_m;
    // One registration per thread, each on one thread: the edges run in parallel.
    for (int t = 0; t < std::max(1, params.num_threads); ++t) registrations.emplace_back(g);
    scratch.resize(registrations.size());
}

TrackScratch* FusionEngine::Impl::thread_scratch() {
    return &scratch[static_cast<std::size_t>(omp_get_thread_num())];
}

FusionEngine::Impl::~Impl() {
    if (pending) pending->job->cancel();
}

// The continuous registration of one frame (PAPER.md), in the paper's steps.
FrameOutput FusionEngine::Impl::process(const FrameInput& in) {
    const Stopwatch frame_time;
    FrameWork w = begin_frame(in);
    if (in.sensors.size() != n) return std::move(w.out);  // wrong shape: nothing invented
    if (!initialise(in, &w)) return std::move(w.out);     // 1. initial registration
    prepare_tracks(in, &w);                               // 2. crop, deskew, dynamics, targets
    register_edges(&w);                                   // 3. G-ICP edges
    solve_graph(&w);                                      // 4. pose graph
    report_poses(&w);                                     // 5. poses and health
    report_edges(&w);
    detect_divergence(&w);
    slide_window(in, w);
    last_registered_health = w.out.health;
    build_fused_cloud(&w);  // 6. the fused cloud
    w.out.timings.total_ms = frame_time.milliseconds();
    return std::move(w.out);
}

// The frame's index and output shape; which scans are usable (there and holding enough
// points: an empty one counts as missing).
FrameWork FusionEngine::Impl::begin_frame(const FrameInput& in, bool registered) {
    FrameWork w;
    w.frame = registered ? frame_counter++ : frame_counter - 1;
    FrameOutput& out = w.out;
    out.frame_index = output_counter++;
    out.registered = registered;
    out.T_root_sensor.assign(n, Eigen::Isometry3d::Identity());
    out.t_ns.assign(n, 0);
    out.health.assign(n, SensorHealth{});
    out.cloud = std::exchange(spare_cloud, FusedCloud{});  // empty, or a recycled cloud's buffers
    out.cloud.clear();
    if (in.sensors.size() != n) return w;
    w.usable.assign(n, 0);
    for (std::size_t s = 0; s < n; ++s) {
        const auto& scan = in.sensors[s];
        w.usable[s] = usable(scan);
        out.t_ns[s] = scan.t_ns;
        out.health[s].included = w.usable[s] != 0;
        out.health[s].points_in = scan.points.size();
        if (scan.present && !w.usable[s]) {
            out.health[s].event_is_problem = true;
            out.health[s].event = "scan with " + std::to_string(scan.points.size()) +
                                  " points skipped (fewer than " +
                                  std::to_string(params.min_scan_points) + ")";
        }
    }
    return w;
}

// Step 1. One initial registration at a time: apply a finished one; start one for the root
// and every sensor on the first frame the root is there, or for the sensors that need one.
// False while the station's first registration waits for the root's scan.
bool FusionEngine::Impl::initialise(const FrameInput& in, FrameWork* w) {
    const std::size_t root = params.root_sensor;
    started_first.assign(n, false);
    const Stopwatch init_time;
    if (pending && pending->job->done()) apply_initialisation(w->frame, &w->started, &w->out);
    if (!pending && !tracks[root]->initialised()) {
        if (!w->usable[root]) return false;
        std::vector<std::size_t> all;
        for (std::size_t s = 0; s < n; ++s) {
            if (w->usable[s]) all.push_back(s);
        }
        request_initialisation(w->frame, in, all, true, Eigen::Isometry3d::Identity(), &w->started,
                               &w->out);
    } else if (!pending && w->usable[root]) {
        reinitialise_due_sensors(in, w);
    }
    w->out.initial_registration_pending = pending.has_value();
    w->out.timings.initial_ms = init_time.milliseconds();
    return true;
}

// Sensors that failed their registration (retried now and then) and diverged ones (at once)
// are registered again, relative to the root's pose predicted for this frame.
void FusionEngine::Impl::reinitialise_due_sensors(const FrameInput& in, FrameWork* w) {
    const std::size_t root = params.root_sensor;
    std::vector<std::size_t> wanted;
    const bool retry_due = w->frame - last_retry_frame >= params.retry_interval_frames;
    for (std::size_t s = 0; s < n; ++s) {
        if (s == root || !w->usable[s]) continue;
        if (needs_reinit[s] || (!tracks[s]->initialised() && retry_due)) wanted.push_back(s);
    }
    if (wanted.empty()) return;
    // A diverged sensor stops tracking until it is registered again.
    for (std::size_t s : wanted) {
        if (tracks[s]->initialised()) remove_track_nodes(s);
        tracks[s]->reset();
        needs_reinit[s] = false;
    }
    const Eigen::Isometry3d T_root_now = tracks[root]->predict(in.sensors[root].t_ns);
    request_initialisation(w->frame, in, wanted, false, T_root_now, &w->started, &w->out);
}

// Step 2. Every tracked sensor with a scan, in parallel: its pose predicted, its scan cropped,
// deskewed, split into static and dynamic points and made a G-ICP target.
void FusionEngine::Impl::prepare_tracks(const FrameInput& in, FrameWork* w) {
    const Stopwatch prep_time;
    w->reanchored = params.deskew && reanchor_references(w->frame, w->usable, w->started);
    // The first registration's references: fine edges at once (with deskew they are
    // replaced when the references are deskewed). At 3 m the tracking-voxel edges alone
    // leave the initial registration's error (tens of cm) in the first frames.
    std::vector<std::size_t> first;
    for (std::size_t s : w->started) {
        if (started_first[s]) first.push_back(s);
    }
    add_fine_reference_edges(first, false);
    w->predicted.assign(n, Eigen::Isometry3d::Identity());
    for (std::size_t s = 0; s < n; ++s) {
        if (!tracks[s]->initialised()) continue;
        w->predicted[s] =
            w->is_started(s) ? tracks[s]->reference_pose() : tracks[s]->predict(in.sensors[s].t_ns);
        if (w->usable[s]) w->active.push_back(s);
    }
    const int threads = std::max(1, params.num_threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t k = 0; k < w->active.size(); ++k) {
        const std::size_t s = w->active[k];
        if (!is_fresh(*w, s)) tracks[s]->prepare(in.sensors[s], w->predicted[s], thread_scratch());
    }
    w->out.timings.preprocess_ms = prep_time.milliseconds();
}

// Step 3. G-ICP of each sensor against its previous and reference scans, every frame, and
// between sensors every (window - 1) frames and whenever a reference changed; in parallel.
void FusionEngine::Impl::register_edges(FrameWork* w) {
    const Stopwatch reg_time;
    plan_track_edges(w);
    const int interval = std::max(1, params.window_frames - 1);
    if (w->frame % interval == 0 || !w->started.empty() || w->reanchored)
        plan_inter_sensor_edges(w);
    const int threads = std::max(1, params.num_threads);
    auto& tasks = w->tasks;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t k = 0; k < tasks.size(); ++k) {
        auto& task = tasks[k];
        GicpRegistration& registration =
            registrations[static_cast<std::size_t>(omp_get_thread_num())];
        task.result = registration.align(*task.target, *task.source, task.T_init, task.guess);
        // One reference edge per sensor: no two tasks write to the same track.
        if (task.kind == EdgeKind::kReference) {
            tracks[task.source_sensor]->set_reference_correspondences(
                registration.correspondences());
        }
    }
    w->out.timings.registration_ms = reg_time.milliseconds();
}

// Each active sensor's edges to its own previous frame (while that node is in the graph)
// and to its reference frame, first correspondences guessed from the previous frame.
void FusionEngine::Impl::plan_track_edges(FrameWork* w) const {
    for (std::size_t s : w->active) {
        if (is_fresh(*w, s)) continue;
        const SensorTrack& track = *tracks[s];
        if (track.current_target().size() < 3) continue;
        const auto prev = track.previous();
        if (prev && graph.has_node(node_id(s, prev->frame)) &&
            track.previous_target().size() >= 3) {
            w->tasks.push_back({EdgeKind::kPrevious,
                                s,
                                s,
                                prev->frame,
                                &track.previous_target(),
                                &track.current_target(),
                                prev->T_root_sensor.inverse() * w->predicted[s],
                                {}});
            w->tasks.back().guess = &track.previous_guess();
        }
        if (track.reference_target().size() >= 3) {
            w->tasks.push_back({EdgeKind::kReference,
                                s,
                                s,
                                track.reference_frame(),
                                &track.reference_target(),
                                &track.current_target(),
                                track.reference_pose().inverse() * w->predicted[s],
                                {}});
            w->tasks.back().guess = &track.reference_guess();
        }
    }
}

// Every pair of active sensors on this frame: target the earlier in configuration order.
void FusionEngine::Impl::plan_inter_sensor_edges(FrameWork* w) const {
    const auto& active = w->active;
    for (std::size_t a = 0; a < active.size(); ++a) {
        for (std::size_t b = a + 1; b < active.size(); ++b) {
            const std::size_t j = active[a], i = active[b];  // target j, source i
            const GicpCloud& tj = tracks[j]->current_target();
            const GicpCloud& ti = tracks[i]->current_target();
            if (tj.size() < 3 || ti.size() < 3) continue;
            w->tasks.push_back({EdgeKind::kInterSensor,
                                i,
                                j,
                                w->frame,
                                &tj,
                                &ti,
                                w->predicted[j].inverse() * w->predicted[i],
                                {}});
        }
    }
}

FusionEngine::FusionEngine(std::size_t num_sensors, const FusionParams& params)
    : impl_(std::make_unique<Impl>(num_sensors, params)) {}
FusionEngine::~FusionEngine() = default;
FrameOutput FusionEngine::process(const FrameInput& frame, FrameMode mode) {
    if (mode == FrameMode::kPredict) {
        if (auto poses = impl_->predicted_poses(frame))
            return impl_->process_predicted(frame, std::move(*poses));
    }
    return impl_->process(frame);
}
void FusionEngine::recycle(FusedCloud cloud) { impl_->spare_cloud = std::move(cloud); }
const FusionParams& FusionEngine::params() const { return impl_->params; }
std::size_t FusionEngine::num_sensors() const { return impl_->n; }

}  // namespace lidarfuse::core
