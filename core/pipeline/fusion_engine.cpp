#include "core/pipeline/fusion_engine.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <optional>
#include <set>

#include "core/pipeline/initial_registration_job.hpp"
#include "core/pipeline/sensor_track.hpp"
#include "core/pose_graph.hpp"

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

PoseGraph::NodeId node_id(std::size_t sensor, std::int64_t frame) {
    return frame * 64 + static_cast<std::int64_t>(sensor);
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
};

// An initial registration handed out (or run inline) and what applying it needs.
struct PendingInitialisation {
    std::shared_ptr<InitialRegistrationJob> job;
    std::int64_t frame = 0;               // the frame of its scans
    bool first = false;                   // the station's first registration
    std::vector<std::size_t> order;       // the root, then the sensors to register
    std::vector<SensorScanInput> scans;   // their scans of `frame`, in `order`
    Eigen::Isometry3d T_root0_root = Eigen::Isometry3d::Identity();  // root pose at `frame`
};

}  // namespace

struct FusionEngine::Impl {
    FusionParams params;
    std::size_t n;
    std::vector<std::unique_ptr<SensorTrack>> tracks;
    PoseGraph graph;
    std::vector<GicpRegistration> registrations;  // one per thread
    std::int64_t frame_counter = 0;
    std::int64_t last_retry_frame = -1'000'000;
    std::vector<int> suspicious;         // consecutive suspicious frames per sensor
    std::vector<bool> needs_reinit;
    std::set<PoseGraph::NodeId> window_nodes;  // non-reference nodes in the graph
    std::optional<PendingInitialisation> pending;
    std::vector<bool> started_first;  // this frame: started by the station's first registration
    // Deskew (FusionParams::deskew): edges measured between reference nodes in their own
    // frame (from skewed scans), removed when those references are deskewed; per sensor the
    // frame its reference was re-anchored (reference nodes stay free for a window after).
    struct ReferenceEdge {
        PoseGraph::EdgeId edge;
        std::size_t a, b;
    };
    std::vector<ReferenceEdge> reference_edges;
    std::vector<std::int64_t> reanchored_frame;
    std::optional<Eigen::Isometry3d> root_reanchor;  // left factor for the root's batch
    std::int64_t root_reanchor_reference = -1;       // the root reference frame it belongs to

    Impl(std::size_t num_sensors, const FusionParams& p)
        : params(p), n(num_sensors), graph(graph_params(p)), suspicious(num_sensors, 0),
          needs_reinit(num_sensors, false), started_first(num_sensors, false),
          reanchored_frame(num_sensors, -1) {
        for (std::size_t i = 0; i < n; ++i) tracks.push_back(std::make_unique<SensorTrack>(params));
        GicpParams g = params.gicp;
        g.max_correspondence_distance_m = params.correspondence_factor * params.voxel_size_m;
        g.num_threads = 1;  // edges already run in parallel
        for (int t = 0; t < std::max(1, params.num_threads); ++t) registrations.emplace_back(g);
    }

    // A worker that has not begun the job yet can skip it; the job outlives the engine.
    ~Impl() {
        if (pending) pending->job->cancel();
    }

    static PoseGraphParams graph_params(const FusionParams& p) {
        PoseGraphParams g;
        g.huber_delta = p.huber_delta;
        g.num_threads = 1;
        return g;
    }

    // Starts an initial registration of `sensors` on this frame's scans, relative to the
    // root's pose at this frame (T_root0_root_now). Inline: runs and applies it at once.
    // Otherwise hands it out in out->initial_job; on the station's first frame the root
    // starts tracking right away (its pose is the identity by definition).
    void request_initialisation(std::int64_t frame, const FrameInput& in,
                                const std::vector<std::size_t>& sensors, bool first,
                                const Eigen::Isometry3d& T_root0_root_now,
                                std::vector<std::size_t>* started, FrameOutput* out) {
        const std::size_t root = params.root_sensor;
        PendingInitialisation p;
        p.frame = frame;
        p.first = first;
        p.T_root0_root = T_root0_root_now;
        p.order.push_back(root);
        for (std::size_t s : sensors) {
            if (s != root) p.order.push_back(s);
        }
        const bool run_inline = params.initial_registration_inline;
        if (!run_inline && first) {
            tracks[root]->start(frame, in.sensors[root], Eigen::Isometry3d::Identity());
            graph.add_node(node_id(root, frame), Eigen::Isometry3d::Identity(), true);
            started->push_back(root);
            started_first[root] = true;
            out->health[root].event = "initialised";
            if (p.order.size() == 1) return;  // a station of one: nothing to register
        }
        std::vector<PointCloud> clouds;
        for (std::size_t s : p.order) {
            p.scans.push_back(in.sensors[s]);
            PointCloud c;
            c.points = in.sensors[s].points;
            clouds.push_back(std::move(c));
        }
        InitialRegistrationParams ip = params.initial;
        ip.num_threads = std::max(1, run_inline ? params.num_threads : params.initial_threads);
        p.job = std::make_shared<InitialRegistrationJob>(std::move(clouds), ip);
        pending = std::move(p);
        if (run_inline) {
            pending->job->run();
            apply_initialisation(frame, started, out);
        } else {
            out->initial_job = pending->job;
            for (std::size_t k = 1; k < pending->order.size(); ++k) {
                out->health[pending->order[k]].event = "initial registration started";
            }
        }
    }

    // Starts the tracks of the sensors the finished job registered. Their reference frame is
    // the job's frame (its scans); when that is an earlier frame, they are tracked from this
    // frame on like any sensor (reference edge from the registered pose, inter-sensor edges).
    void apply_initialisation(std::int64_t frame, std::vector<std::size_t>* started, FrameOutput* out) {
        const PendingInitialisation p = std::move(*pending);
        pending.reset();
        const auto& result = p.job->result();
        bool any_failed = false;
        for (std::size_t k = 0; k < p.order.size(); ++k) {
            const std::size_t s = p.order[k];
            const bool is_root = s == params.root_sensor;
            if (is_root && tracks[s]->initialised()) continue;  // only a reference here
            if (k >= result.sensors.size() || !result.sensors[k].registered) {
                out->health[s].event =
                    std::string("initial registration failed: ") +
                    (k < result.sensors.size() ? to_string(result.sensors[k].status) : p.job->error().c_str());
                any_failed = true;
                continue;
            }
            const Eigen::Isometry3d T = p.T_root0_root * result.sensors[k].T_root_sensor;
            tracks[s]->start(p.frame, p.scans[k], T);
            graph.add_node(node_id(s, p.frame), T, is_root);
            started->push_back(s);
            started_first[s] = p.first;
            reanchored_frame[s] = -1;
            out->health[s].event = p.first || is_root ? "initialised" : "reinitialised";
            suspicious[s] = 0;
            needs_reinit[s] = false;
        }
        if (p.first || any_failed) last_retry_frame = frame;
    }

    void remove_track_nodes(std::size_t s) {
        for (auto it = window_nodes.begin(); it != window_nodes.end();) {
            if (*it % 64 == static_cast<std::int64_t>(s)) {
                graph.remove_node(*it);
                it = window_nodes.erase(it);
            } else {
                ++it;
            }
        }
        if (tracks[s]->initialised()) graph.remove_node(node_id(s, tracks[s]->reference_frame()));
        reference_edges.erase(std::remove_if(reference_edges.begin(), reference_edges.end(),
                                             [s](const ReferenceEdge& e) { return e.a == s || e.b == s; }),
                              reference_edges.end());
    }

    // Deskews the reference scans whose motion is now known and re-anchors their poses to
    // the scan timestamps (SensorTrack::deskew_reference). The root goes first: its
    // correction changes the meaning of the root frame, so the sensors registered against
    // its reference get it as a left factor (sensors registered later, against a
    // not-yet-deskewed root frame, keep a residual of the root's motion over half a sweep).
    // Everything measured in the old meaning -- the sensor's window nodes and the edges
    // between reference frames -- leaves the graph. Returns whether any sensor re-anchored.
    bool reanchor_references(std::int64_t frame, const std::vector<char>& usable,
                             const std::vector<std::size_t>& started) {
        const std::size_t root = params.root_sensor;
        std::vector<std::size_t> order{root};
        for (std::size_t s = 0; s < n; ++s) {
            if (s != root) order.push_back(s);
        }
        bool any = false;
        std::vector<std::size_t> batch;  // re-anchored with the root's reference frame
        for (std::size_t s : order) {
            SensorTrack& track = *tracks[s];
            if (!track.initialised() || !usable[s]) continue;
            if (std::find(started.begin(), started.end(), s) != started.end()) continue;
            const auto right = track.deskew_reference(frame);
            if (!right) continue;
            Eigen::Isometry3d left = Eigen::Isometry3d::Identity();
            if (s == root) {
                root_reanchor = right->inverse();
                root_reanchor_reference = track.reference_frame();
                left = *root_reanchor;
            } else if (root_reanchor && track.reference_frame() == root_reanchor_reference) {
                left = *root_reanchor;
            }
            track.reanchor(left, *right);
            for (auto it = window_nodes.begin(); it != window_nodes.end();) {
                if (*it % 64 == static_cast<std::int64_t>(s)) {
                    graph.remove_node(*it);
                    it = window_nodes.erase(it);
                } else {
                    ++it;
                }
            }
            for (auto it = reference_edges.begin(); it != reference_edges.end();) {
                if (it->a == s || it->b == s) {
                    graph.remove_edge(it->edge);
                    it = reference_edges.erase(it);
                } else {
                    ++it;
                }
            }
            const auto ref = node_id(s, track.reference_frame());
            if (s != root) {
                graph.set_node_fixed(ref, false);
                graph.set_node_pose(ref, track.reference_pose());
            }
            reanchored_frame[s] = frame;
            if (track.reference_frame() == root_reanchor_reference) batch.push_back(s);
            any = true;
        }
        add_fine_reference_edges(batch, true);
        return any;
    }

    // G-ICP between the reference scans of `sensors` (pairs whose references share a frame)
    // at the fine voxel size, as edges between their reference nodes (see
    // FusionParams::reference_voxel_size_m). One-off: a few hundred ms on 4 sensors.
    // Pairs: at least one of `fresh`, the other any sensor whose reference is final (deskew
    // on: deskewed) and shares the frame.
    void add_fine_reference_edges(const std::vector<std::size_t>& fresh, bool deskewed_only) {
        if (!(params.reference_voxel_size_m > 0) || fresh.empty()) return;
        std::vector<std::size_t> sensors;
        for (std::size_t s = 0; s < n; ++s) {
            const SensorTrack& t = *tracks[s];
            if (!t.initialised() || (deskewed_only && !t.reference_deskewed())) continue;
            const bool is_fresh = std::find(fresh.begin(), fresh.end(), s) != fresh.end();
            bool shares = false;
            for (std::size_t f : fresh) shares = shares || tracks[f]->reference_frame() == t.reference_frame();
            if (is_fresh || shares) sensors.push_back(s);
        }
        const auto in_fresh = [&](std::size_t s) {
            return std::find(fresh.begin(), fresh.end(), s) != fresh.end();
        };
        std::vector<GicpTarget> targets(sensors.size());
        const int threads = std::max(1, params.num_threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
        for (std::size_t k = 0; k < sensors.size(); ++k) {
            targets[k] = tracks[sensors[k]]->reference_target_at(params.reference_voxel_size_m);
        }
        struct Pair {
            std::size_t a, b;  // indices into sensors: target a, source b
            Eigen::Isometry3d T_init;
            GicpResult result;
        };
        std::vector<Pair> pairs;
        for (std::size_t a = 0; a < sensors.size(); ++a) {
            for (std::size_t b = a + 1; b < sensors.size(); ++b) {
                const SensorTrack& ta = *tracks[sensors[a]];
                const SensorTrack& tb = *tracks[sensors[b]];
                if (ta.reference_frame() != tb.reference_frame()) continue;
                if (!in_fresh(sensors[a]) && !in_fresh(sensors[b])) continue;
                if (targets[a].size() < 3 || targets[b].size() < 3) continue;
                pairs.push_back({a, b, ta.reference_pose().inverse() * tb.reference_pose(), {}});
            }
        }
        GicpParams g = params.gicp;
        g.max_correspondence_distance_m = params.correspondence_factor * params.reference_voxel_size_m;
        g.num_threads = 1;
        std::vector<GicpRegistration> fine(static_cast<std::size_t>(threads), GicpRegistration(g));
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
        for (std::size_t k = 0; k < pairs.size(); ++k) {
            auto& pair = pairs[k];
            pair.result = fine[static_cast<std::size_t>(omp_get_thread_num())].align(
                targets[pair.a], targets[pair.b].cloud(), pair.T_init);
        }
        for (const auto& pair : pairs) {
            const auto& r = pair.result;
            if (!r.converged && r.status != GicpStatus::kMaxIterations) continue;
            if (r.inlier_ratio < 0.5 * params.min_fitness) continue;
            const std::size_t sa = sensors[pair.a], sb = sensors[pair.b];
            const auto e = graph.add_edge(node_id(sa, tracks[sa]->reference_frame()),
                                          node_id(sb, tracks[sb]->reference_frame()),
                                          r.T_target_source, calibrated_information(r));
            if (e >= 0) reference_edges.push_back({e, sa, sb});
        }
    }

    Matrix6d calibrated_information(const GicpResult& r) const {
        const double scale = r.mean_error > 1e-12 ? 3.0 / r.mean_error : 1.0;
        return r.H * scale;
    }

    FrameOutput process(const FrameInput& in) {
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
                }
            }
            if (track.reference_target().size() >= 3) {
                tasks.push_back({EdgeKind::kReference, s, s, track.reference_frame(),
                                 &track.reference_target(), &track.current_target(),
                                 track.reference_pose().inverse() * predicted[s], {}});
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
            task.result = registrations[static_cast<std::size_t>(omp_get_thread_num())].align(
                *task.target, task.source->cloud(), task.T_init);
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
        for (std::size_t s : active) track_finish(s, frame, in.sensors[s].t_ns, out.T_root_sensor[s]);
        // Nodes older than the window leave (their edges with them).
        for (auto it = window_nodes.begin(); it != window_nodes.end();) {
            if (*it / 64 <= frame - params.window_frames) {
                graph.remove_node(*it);
                it = window_nodes.erase(it);
            } else {
                ++it;
            }
        }

        // 6. The fused cloud, in the root frame.
        const auto t_fuse = Clock::now();
        if (params.build_fused_cloud) {
            for (std::size_t s : active) {
                const SensorTrack& track = *tracks[s];
                const Eigen::Isometry3f T = out.T_root_sensor[s].cast<float>();
                const auto& pts = track.current_points();
                for (std::size_t k = 0; k < pts.size(); ++k) {
                    out.cloud.points.push_back(T * pts[k].cast<float>());
                    out.cloud.intensity.push_back(track.current_intensity()[k]);
                    out.cloud.sensor.push_back(static_cast<std::uint8_t>(s));
                    out.cloud.dynamic.push_back(track.current_dynamic()[k]);
                }
            }
        }
        out.timings.fuse_ms = ms_since(t_fuse);
        out.timings.total_ms = ms_since(t_start);
        return out;
    }

    void track_finish(std::size_t s, std::int64_t frame, std::int64_t t_ns, const Eigen::Isometry3d& T) {
        tracks[s]->finish_frame(frame, t_ns, T);
    }
};

FusionEngine::FusionEngine(std::size_t num_sensors, const FusionParams& params)
    : impl_(std::make_unique<Impl>(num_sensors, params)) {}
FusionEngine::~FusionEngine() = default;
FrameOutput FusionEngine::process(const FrameInput& frame) { return impl_->process(frame); }
const FusionParams& FusionEngine::params() const { return impl_->params; }
std::size_t FusionEngine::num_sensors() const { return impl_->n; }

}  // namespace lidarfuse::core
