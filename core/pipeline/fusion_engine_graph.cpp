// FusionEngine::process, steps 4-6: the pose graph of the sliding window, the poses and
// health it gives, the window moving on, and the fused cloud (see fusion_engine_impl.hpp).
#include <algorithm>
#include <cmath>
#include <map>

#include "core/common/se3.hpp"
#include "core/pipeline/fusion_engine_impl.hpp"

namespace lidarfuse::core {

// Step 4. This frame's nodes at their predicted poses, the converged edges, one solve. A
// node with no edge at all would float: it is held at its prediction for this solve.
void FusionEngine::Impl::solve_graph(FrameWork* w) {
    const Stopwatch graph_time;
    for (std::size_t s : w->active) {
        if (!is_fresh(*w, s)) window.add(s, w->frame, w->predicted[s]);
    }
    const std::vector<PoseGraph::NodeId> held = add_edges(w);
    for (auto id : held) graph.set_node_fixed(id, true);
    w->out.graph_usable = graph.optimize().usable;
    for (auto id : held) graph.set_node_fixed(id, false);
    w->out.timings.graph_ms = graph_time.milliseconds();
}

// Adds the edges that converged (inter-sensor ones also need half the minimum fitness);
// returns this frame's nodes that got none.
std::vector<PoseGraph::NodeId> FusionEngine::Impl::add_edges(FrameWork* w) {
    std::map<PoseGraph::NodeId, int> degree;
    for (const auto& task : w->tasks) {
        const auto& r = task.result;
        if (!r.converged && r.status != GicpStatus::kMaxIterations) continue;
        if (r.inlier_ratio < 0.5 * params.min_fitness && task.kind == EdgeKind::kInterSensor)
            continue;
        const auto a = node_id(task.target_sensor, task.target_frame);
        const auto b = node_id(task.source_sensor, w->frame);
        const auto e = graph.add_edge(a, b, r.T_target_source, calibrated_information(r));
        if (e < 0) continue;
        ++degree[a];
        ++degree[b];
        w->edges.emplace_back(e, task.source_sensor);
        if (params.deskew && task.kind == EdgeKind::kInterSensor &&
            tracks[task.source_sensor]->reference_frame() == w->frame &&
            tracks[task.target_sensor]->reference_frame() == w->frame) {
            reference_edges.push_back({e, task.source_sensor, task.target_sensor});
        }
    }
    std::vector<PoseGraph::NodeId> unconnected;
    for (std::size_t s : w->active) {
        const auto id = node_id(s, w->frame);
        if (!is_fresh(*w, s) && degree[id] == 0) unconnected.push_back(id);
    }
    return unconnected;
}

// Step 5. Each sensor's pose (the graph's, or its prediction when the solve was unusable)
// and its state and point counts.
void FusionEngine::Impl::report_poses(FrameWork* w) {
    FrameOutput& out = w->out;
    for (std::size_t s = 0; s < n; ++s) {
        SensorHealth& h = out.health[s];
        const SensorTrack& track = *tracks[s];
        if (!track.initialised()) {
            h.state = TrackState::kUninitialised;
            continue;
        }
        h.pose_valid = true;
        const bool present = w->usable[s];
        const auto node = graph.node_pose(node_id(s, w->frame));
        out.T_root_sensor[s] = node && out.graph_usable ? *node : w->predicted[s];
        if (w->is_started(s)) {
            h.state = started_first[s] ? TrackState::kTracking : TrackState::kReinitialised;
        } else {
            h.state = present ? TrackState::kTracking : TrackState::kMissing;
        }
        if (!present) continue;
        h.static_points = track.current_points().size() - track.current_dynamic_count();
        h.dynamic_points = track.current_dynamic_count();
        h.registration_points = track.current_target().size();
    }
    // A job handed out this frame: its poses are relative to the root's estimate here (set
    // before process() hands the job out, which its follow-up then reads on its own thread).
    if (pending && pending->frame == w->frame && out.health[params.root_sensor].pose_valid) {
        pending->starts->T_root0_root = out.T_root_sensor[params.root_sensor];
    }
}

// Step 5. What each sensor's edges say: fitness, inliers, the reference edge's weakest
// direction, and the largest residual (in sigmas) of its edges after the solve.
void FusionEngine::Impl::report_edges(FrameWork* w) const {
    FrameOutput& out = w->out;
    for (const auto& task : w->tasks) {
        SensorHealth& h = out.health[task.source_sensor];
        if (task.kind == EdgeKind::kPrevious) h.fitness_previous = task.result.inlier_ratio;
        if (task.kind == EdgeKind::kReference) {
            h.fitness_reference = task.result.inlier_ratio;
            h.inliers_reference = task.result.num_inliers;
            h.min_hessian_eigenvalue = task.result.H_eigenvalues(0);
        }
    }
    for (const auto& [edge, sensor] : w->edges) {
        if (const auto r = graph.edge_residual(edge)) {
            SensorHealth& h = out.health[sensor];
            h.max_edge_residual_sigma = std::max(h.max_edge_residual_sigma, std::sqrt(r->chi2));
        }
    }
}

// Step 5. A sensor whose reference fitness is low or whose pose jumped from its prediction
// for divergence_frames frames in a row is registered again from scratch (next frame).
void FusionEngine::Impl::detect_divergence(FrameWork* w) {
    FrameOutput& out = w->out;
    for (std::size_t s : w->active) {
        if (w->is_started(s) || s == params.root_sensor) continue;
        SensorHealth& h = out.health[s];
        const double jump_m =
            (out.T_root_sensor[s].translation() - w->predicted[s].translation()).norm();
        const double jump_deg =
            rotation_angle_deg(out.T_root_sensor[s].rotation(), w->predicted[s].rotation());
        const bool bad = h.fitness_reference < params.min_fitness || jump_m > params.max_jump_m ||
                         jump_deg > params.max_jump_deg;
        suspicious[s] = bad ? suspicious[s] + 1 : 0;
        if (suspicious[s] >= params.divergence_frames) {
            needs_reinit[s] = true;
            h.event = "diverged: registering again from scratch";
            h.event_is_problem = true;
        }
    }
}

// Step 5. The window moves on: reference poses take the graph's refinement (fixed once a
// window past their frame), each track keeps this frame as its previous one, and nodes
// older than the window leave.
void FusionEngine::Impl::slide_window(const FrameInput& in, const FrameWork& w) {
    for (std::size_t s = 0; s < n; ++s) {
        SensorTrack& track = *tracks[s];
        if (!track.initialised()) continue;
        const auto ref = node_id(s, track.reference_frame());
        if (const auto pose = graph.node_pose(ref)) track.set_reference_pose(*pose);
        window.settle_reference(ref, std::max(track.reference_frame(), reanchored_frame[s]),
                                w.frame);
    }
    for (std::size_t s : w.active)
        tracks[s]->finish_frame(w.frame, in.sensors[s].t_ns, w.out.T_root_sensor[s]);
    window.slide(w.frame);
}

// Step 6. Each sensor's points, in the root frame, in configuration order: sized once, then
// every sensor fills its own slice. Serial: a copy at memory speed gains nothing from a
// second thread that a loaded machine may not schedule at once.
void FusionEngine::Impl::build_fused_cloud(FrameWork* w) const {
    const Stopwatch fuse_time;
    if (params.build_fused_cloud) copy_fused_points(w->active, &w->out);
    w->out.timings.fuse_ms = fuse_time.milliseconds();
}

void FusionEngine::Impl::copy_fused_points(const std::vector<std::size_t>& active,
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

}  // namespace lidarfuse::core
