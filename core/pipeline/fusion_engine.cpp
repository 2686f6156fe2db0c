#include "core/pipeline/fusion_engine.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <map>

#include "core/pipeline/fusion_engine_impl.hpp"

namespace lidarfuse::core {

const char* to_string(TrackState state) {
    switch (state) {
        case TrackState::kUninitialised: return "uninitialised";
        case TrackState::kTracking: return "tracking";
        case TrackState::kMissing: return "missing";
        case TrackState::kReinitialised: return "reinitialised";
    }
    return "unknown";
}

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

PoseGraphParams graph_params(const FusionParams& p) {
    PoseGraphParams g;
    g.huber_delta = p.huber_delta;
    g.max_iterations = p.graph_max_iterations;
    g.num_threads = 1;
    return g;
}

enum class EdgeKind { kPrevious, kReference, kInterSensor };

struct EdgeTask {
    EdgeKind kind;
    std::size_t source_sensor;
    std::size_t target_sensor;
    std::int64_t target_frame;
    const GicpTarget* target;
    const GicpTarget* source;  // its cloud is the source
    Eigen::Isometry3d T_init;  // T_target_source
    GicpResult result;
    const std::vector<std::int32_t>* guess = nullptr;  // GicpRegistration::align
};

}  // namespace

FusionEngine::Impl::Impl(std::size_t num_sensors, const FusionParams& p)
    : params(p), n(num_sensors), graph(graph_params(p)), suspicious(num_sensors, 0),
      needs_reinit(num_sensors, false), started_first(num_sensors, false), reanchored_frame(num_sensors, -1) {
    for (std::size_t i = 0; i < n; ++i) tracks.push_back(std::make_unique<SensorTrack>(params));
    GicpParams g = params.gicp;
    g.max_correspondence_distance_m = params.correspondence_factor * params.voxel_size_m;
    g.num_threads = 1;  // edges already run in parallel
    for (int t = 0; t < std::max(1, params.num_threads); ++t) registrations.emplace_back(g);
}

FusionEngine::Impl::~Impl() {
    if (pending) pending->job->cancel();
}

FrameOutput FusionEngine::Impl::process(const FrameInput& in) {
    const auto t_start = Clock::now();
    const std::int64_t frame = frame_counter++;
    FrameOutput out;
    out.frame_index = frame;
    out.T_root_sensor.assign(n, Eigen::Isometry3d::Identity());
    out.t_ns.assign(n, 0);
    out.health.assign(n, SensorHealth{});
    if (in.sensors.size() != n) return out;  // wrong shape: nothing to do, nothing invented
    // usable: the scan is there and holds enough points; an empty one counts as missing.
    std::vector<char> usable(n, 0);
    for (std::size_t s = 0; s < n; ++s) {
        const auto& scan = in.sensors[s];
        usable[s] = scan.present && scan.points.size() >= params.min_scan_points;
        out.t_ns[s] = scan.t_ns;
        out.health[s].included = usable[s] != 0;
        out.health[s].points_in = scan.points.size();
        if (scan.present && !usable[s]) {
            out.health[s].event_is_problem = true;
            out.health[s].event = "scan with " + std::to_string(scan.points.size()) +
                                  " points skipped (fewer than " +
                                  std::to_string(params.min_scan_points) + ")";
        }
    }
    const std::size_t root = params.root_sensor;

    // 1. Initial registration, one job at a time: apply a finished one; start one for the
    // root and every sensor on the first frame the root is there, for sensors that
    // failed (retried now and then) and for diverged sensors (at once).
    std::vector<std::size_t> started;
    started_first.assign(n, false);
    const auto t_init = Clock::now();
    if (pending && pending->job->done()) apply_initialisation(frame, &started, &out);
    if (!pending && !tracks[root]->initialised()) {
        if (!usable[root]) return out;
        std::vector<std::size_t> all;
        for (std::size_t s = 0; s < n; ++s) {
            if (usable[s]) all.push_back(s);
        }
        request_initialisation(frame, in, all, true, Eigen::Isometry3d::Identity(), &started, &out);
    } else if (!pending && usable[root]) {
        std::vector<std::size_t> wanted;
        const bool retry_due = frame - last_retry_frame >= params.retry_interval_frames;
        for (std::size_t s = 0; s < n; ++s) {
            if (s == root || !usable[s]) continue;
            if (needs_reinit[s] || (!tracks[s]->initialised() && retry_due)) wanted.push_back(s);
        }
        if (!wanted.empty()) {
            // A diverged sensor stops tracking until it is registered again.
            for (std::size_t s : wanted) {
                if (tracks[s]->initialised()) remove_track_nodes(s);
                tracks[s]->reset();
                needs_reinit[s] = false;
            }
            const Eigen::Isometry3d T_root_now = tracks[root]->predict(in.sensors[root].t_ns);
            request_initialisation(frame, in, wanted, false, T_root_now, &started, &out);
        }
    }
    out.initial_registration_pending = pending.has_value();
    out.timings.initial_ms = ms_since(t_init);
    const auto is_started = [&](std::size_t s) {
        return std::find(started.begin(), started.end(), s) != started.end();
    };
    // Started on this very frame's scan (its reference): nothing to register this frame.
    const auto is_fresh = [&](std::size_t s) {
        return is_started(s) && tracks[s]->reference_frame() == frame;
    };

    // 2. Prepare every tracked sensor with a scan (in parallel).
    const auto t_prep = Clock::now();
    const bool reanchored = params.deskew && reanchor_references(frame, usable, started);
    {
        // The first registration's references: fine edges at once (with deskew they are
        // replaced when the references are deskewed). At 3 m the tracking-voxel edges
        // alone leave the initial registration's error (tens of cm) in the first frames.
        std::vector<std::size_t> first;
        for (std::size_t s : started) {
            if (started_first[s]) first.push_back(s);
        }
        add_fine_reference_edges(first, false);
    }
    std::vector<std::size_t> active;
    std::vector<Eigen::Isometry3d> predicted(n, Eigen::Isometry3d::Identity());
    for (std::size_t s = 0; s < n; ++s) {
        if (!tracks[s]->initialised()) continue;
        predicted[s] = is_started(s) ? tracks[s]->reference_pose()
                                     : tracks[s]->predict(in.sensors[s].t_ns);
        if (usable[s]) active.push_back(s);
    }
    const int threads = std::max(1, params.num_threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t k = 0; k < active.size(); ++k) {
        const std::size_t s = active[k];
        if (!is_fresh(s)) tracks[s]->prepare(in.sensors[s], predicted[s]);
    }
    out.timings.preprocess_ms = ms_since(t_prep);

    // 3. G-ICP edges.
    const auto t_reg = Clock::now();
    std::vector<EdgeTask> tasks;
    for (std::size_t s : active) {
        if (is_fresh(s)) continue;
        SensorTrack& track = *tracks[s];
        if (track.current_target().size() < 3) continue;
        if (const auto prev = track.previous()) {
            if (graph.has_node(node_id(s, prev->frame)) && track.previous_target().size() >= 3) {
                tasks.push_back({EdgeKind::kPrevious, s, s, prev->frame, &track.previous_target(),
                                 &track.current_target(),
                                 prev->T_root_sensor.inverse() * predicted[s], {}});
                tasks.back().guess = &track.previous_guess();
            }
        }
        if (track.reference_target().size() >= 3) {
            tasks.push_back({EdgeKind::kReference, s, s, track.reference_frame(),
                             &track.reference_target(), &track.current_target(),
                             track.reference_pose().inverse() * predicted[s], {}});
            tasks.back().guess = &track.reference_guess();
        }
    }
    const int interval = std::max(1, params.window_frames - 1);
    if (frame % interval == 0 || !started.empty() || reanchored) {
        for (std::size_t a = 0; a < active.size(); ++a) {
            for (std::size_t b = a + 1; b < active.size(); ++b) {
                const std::size_t j = active[a], i = active[b];  // target j, source i
                const GicpTarget& tj = tracks[j]->current_target();
                const GicpTarget& ti = tracks[i]->current_target();
                if (tj.size() < 3 || ti.size() < 3) continue;
                tasks.push_back({EdgeKind::kInterSensor, i, j, frame, &tj, &ti,
                                 predicted[j].inverse() * predicted[i], {}});
            }
        }
    }
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t k = 0; k < tasks.size(); ++k) {
        auto& task = tasks[k];
        GicpRegistration& registration =
            registrations[static_cast<std::size_t>(omp_get_thread_num())];
        task.result =
            registration.align(*task.target, task.source->cloud(), task.T_init, task.guess);
        // One reference edge per sensor: no two tasks write to the same track.
        if (task.kind == EdgeKind::kReference) {
            tracks[task.source_sensor]->set_reference_correspondences(
                registration.correspondences());
        }
    }
    out.timings.registration_ms = ms_since(t_reg);

    // 4. Pose graph: this frame's nodes at the predicted poses, the edges, solve.
    const auto t_graph = Clock::now();
    for (std::size_t s : active) {
        if (is_fresh(s)) continue;
        const auto id = node_id(s, frame);
        graph.add_node(id, predicted[s]);
        window_nodes.insert(id);
    }
    std::map<PoseGraph::NodeId, int> degree;
    std::vector<std::pair<PoseGraph::EdgeId, std::size_t>> edges;  // edge, sensor
    for (const auto& task : tasks) {
        const auto& r = task.result;
        if (!r.converged && r.status != GicpStatus::kMaxIterations) continue;
        if (r.inlier_ratio < 0.5 * params.min_fitness && task.kind == EdgeKind::kInterSensor) continue;
        const auto a = node_id(task.target_sensor, task.target_frame);
        const auto b = node_id(task.source_sensor, frame);
        const auto e = graph.add_edge(a, b, r.T_target_source, calibrated_information(r));
        if (e < 0) continue;
        ++degree[a];
        ++degree[b];
        edges.emplace_back(e, task.source_sensor);
        if (params.deskew && task.kind == EdgeKind::kInterSensor &&
            tracks[task.source_sensor]->reference_frame() == frame &&
            tracks[task.target_sensor]->reference_frame() == frame) {
            reference_edges.push_back({e, task.source_sensor, task.target_sensor});
        }
    }
    // A node with no edge at all would float: hold it at its prediction this frame.
    std::vector<PoseGraph::NodeId> held;
    for (std::size_t s : active) {
        const auto id = node_id(s, frame);
        if (!is_fresh(s) && degree[id] == 0) {
            graph.set_node_fixed(id, true);
            held.push_back(id);
        }
    }
    const auto summary = graph.optimize();
    out.graph_usable = summary.usable;
    for (auto id : held) graph.set_node_fixed(id, false);
    out.timings.graph_ms = ms_since(t_graph);

    // 5. Poses, health, window.
    for (std::size_t s = 0; s < n; ++s) {
        SensorHealth& h = out.health[s];
        SensorTrack& track = *tracks[s];
        if (!track.initialised()) {
            h.state = TrackState::kUninitialised;
            continue;
        }
        h.pose_valid = true;
        const bool present = usable[s];
        const auto node = graph.node_pose(node_id(s, frame));
        out.T_root_sensor[s] = node && summary.usable ? *node : predicted[s];
        if (is_started(s)) {
            h.state = started_first[s] ? TrackState::kTracking : TrackState::kReinitialised;
        } else {
            h.state = present ? TrackState::kTracking : TrackState::kMissing;
        }
        if (!present) continue;
        h.static_points = track.current_points().size() - track.current_dynamic_count();
        h.dynamic_points = track.current_dynamic_count();
        h.registration_points = track.current_target().size();
    }
    // A job handed out this frame: its poses are relative to the root's estimate here.
    if (pending && pending->frame == frame && out.health[root].pose_valid) {
        pending->T_root0_root = out.T_root_sensor[root];
    }
    for (const auto& task : tasks) {
        SensorHealth& h = out.health[task.source_sensor];
        if (task.kind == EdgeKind::kPrevious) h.fitness_previous = task.result.inlier_ratio;
        if (task.kind == EdgeKind::kReference) {
            h.fitness_reference = task.result.inlier_ratio;
            h.inliers_reference = task.result.num_inliers;
            h.min_hessian_eigenvalue = task.result.H_eigenvalues(0);
        }
    }
    for (const auto& [edge, sensor] : edges) {
        if (const auto r = graph.edge_residual(edge)) {
            SensorHealth& h = out.health[sensor];
            h.max_edge_residual_sigma = std::max(h.max_edge_residual_sigma, std::sqrt(r->chi2));
        }
    }
    for (std::size_t s : active) {
        if (is_started(s) || s == root) continue;
        SensorHealth& h = out.health[s];
        const double jump_m = (out.T_root_sensor[s].translation() - predicted[s].translation()).norm();
        const double jump_deg = rotation_angle_deg(out.T_root_sensor[s].rotation(), predicted[s].rotation());
        const bool bad = h.fitness_reference < params.min_fitness || jump_m > params.max_jump_m ||
                         jump_deg > params.max_jump_deg;
        suspicious[s] = bad ? suspicious[s] + 1 : 0;
        if (suspicious[s] >= params.divergence_frames) {
            needs_reinit[s] = true;
            h.event = "diverged: registering again from scratch";
            h.event_is_problem = true;
        }
    }

    // Reference nodes: refined while their frame is in the window, fixed after.
    for (std::size_t s = 0; s < n; ++s) {
        SensorTrack& track = *tracks[s];
        if (!track.initialised()) continue;
        const auto ref = node_id(s, track.reference_frame());
        if (const auto pose = graph.node_pose(ref)) track.set_reference_pose(*pose);
        const std::int64_t since = std::max(track.reference_frame(), reanchored_frame[s]);
        if (frame - since + 1 >= params.window_frames) graph.set_node_fixed(ref, true);
    }
    for (std::size_t s : active) tracks[s]->finish_frame(frame, in.sensors[s].t_ns, out.T_root_sensor[s]);
    // Nodes older than the window leave (their edges with them).
    for (auto it = window_nodes.begin(); it != window_nodes.end();) {
        if (node_frame(*it) <= frame - params.window_frames) {
            graph.remove_node(*it);
            it = window_nodes.erase(it);
        } else {
            ++it;
        }
    }

    // 6. The fused cloud, in the root frame.
    const auto t_fuse = Clock::now();
    if (params.build_fused_cloud) build_fused_cloud(active, &out);
    out.timings.fuse_ms = ms_since(t_fuse);
    out.timings.total_ms = ms_since(t_start);
    return out;
}

// Each sensor's points, in the root frame, in configuration order: sized once, then every
// sensor fills its own slice. Serial: a copy at memory speed gains nothing from a second
// thread that a loaded machine may not schedule at once.
void FusionEngine::Impl::build_fused_cloud(const std::vector<std::size_t>& active,
                                           FrameOutput* out) const {
    std::vector<std::size_t> offset(active.size() + 1, 0);
    for (std::size_t k = 0; k < active.size(); ++k) {
        offset[k + 1] = offset[k] + tracks[active[k]]->current_points().size();
    }
    FusedCloud& cloud = out->cloud;
    cloud.points.resize(offset.back());
    cloud.intensity.resize(offset.back());
    cloud.sensor.resize(offset.back());
    cloud.dynamic.resize(offset.back());
    for (std::size_t k = 0; k < active.size(); ++k) {
        const std::size_t s = active[k];
        const SensorTrack& track = *tracks[s];
        const Eigen::Isometry3f T = out->T_root_sensor[s].cast<float>();
        const auto& pts = track.current_points();
        for (std::size_t j = 0, o = offset[k]; j < pts.size(); ++j, ++o) {
            cloud.points[o] = T * pts[j].cast<float>();
            cloud.intensity[o] = track.current_intensity()[j];
            cloud.sensor[o] = static_cast<std::uint8_t>(s);
            cloud.dynamic[o] = track.current_dynamic()[j];
        }
    }
}

FusionEngine::FusionEngine(std::size_t num_sensors, const FusionParams& params)
    : impl_(std::make_unique<Impl>(num_sensors, params)) {}
FusionEngine::~FusionEngine() = default;
FrameOutput FusionEngine::process(const FrameInput& frame) { return impl_->process(frame); }
const FusionParams& FusionEngine::params() const { return impl_->params; }
std::size_t FusionEngine::num_sensors() const { return impl_->n; }

}  // namespace lidarfuse::core
