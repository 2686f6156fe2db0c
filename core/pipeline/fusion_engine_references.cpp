// FusionEngine's reference frames: re-anchoring deskewed references, the fine edges between
// reference frames, and removing a sensor's nodes (see fusion_engine_impl.hpp).
#include <omp.h>

#include <algorithm>
#include <optional>

#include "core/pipeline/fusion_engine_impl.hpp"

namespace lidarfuse::core {

namespace {

// A fine edge to register: target sensors[a], source sensors[b].
struct FinePair {
    std::size_t a, b;
    Eigen::Isometry3d T_init;
    GicpResult result;
};

// The pairs of `sensors` whose references share a frame, one of them fresh.
template <class InFresh>
std::vector<FinePair> plan_fine_pairs(const std::vector<std::unique_ptr<SensorTrack>>& tracks,
                                      const std::vector<std::size_t>& sensors,
                                      const InFresh& in_fresh) {
    std::vector<FinePair> pairs;
    for (std::size_t a = 0; a < sensors.size(); ++a) {
        for (std::size_t b = a + 1; b < sensors.size(); ++b) {
            const SensorTrack& ta = *tracks[sensors[a]];
            const SensorTrack& tb = *tracks[sensors[b]];
            if (ta.reference_frame() != tb.reference_frame()) continue;
            if (!in_fresh(sensors[a]) && !in_fresh(sensors[b])) continue;
            pairs.push_back({a, b, ta.reference_pose().inverse() * tb.reference_pose(), {}});
        }
    }
    return pairs;
}

// The targets at `voxel_size_m` of the sensors in a pair (null for the others), in parallel:
// a track's own reference target where it is that very cloud (a track just started or
// deskewed), otherwise built into `made`.
std::vector<const GicpCloud*> fine_targets(const std::vector<std::unique_ptr<SensorTrack>>& tracks,
                                           const std::vector<std::size_t>& sensors,
                                           const std::vector<FinePair>& pairs, double voxel_size_m,
                                           int num_threads, std::vector<GicpCloud>* made) {
    std::vector<char> in_pair(sensors.size(), 0);
    for (const FinePair& p : pairs) in_pair[p.a] = in_pair[p.b] = 1;
    std::vector<const GicpCloud*> targets(sensors.size(), nullptr);
#pragma omp parallel for num_threads(std::max(1, num_threads)) schedule(dynamic, 1)
    for (std::size_t k = 0; k < sensors.size(); ++k) {
        if (!in_pair[k]) continue;
        const SensorTrack& track = *tracks[sensors[k]];
        targets[k] = track.reference_target_if_built_at(voxel_size_m);
        if (!targets[k]) {
            (*made)[k] = track.reference_target_at(voxel_size_m);
            targets[k] = &(*made)[k];
        }
    }
    return targets;
}

}  // namespace

void FusionEngine::Impl::remove_track_nodes(std::size_t s) {
    window.remove_sensor(s);
    if (tracks[s]->initialised()) graph.remove_node(node_id(s, tracks[s]->reference_frame()));
    reference_edges.erase(
        std::remove_if(reference_edges.begin(), reference_edges.end(),
                       [s](const ReferenceEdge& e) { return e.a == s || e.b == s; }),
        reference_edges.end());
}

bool FusionEngine::Impl::reanchor_references(std::int64_t frame, const std::vector<char>& usable,
                                             const std::vector<std::size_t>& started) {
    const std::size_t root = params.root_sensor;
    std::vector<std::size_t> order{root};
    for (std::size_t s = 0; s < n; ++s) {
        if (s != root) order.push_back(s);
    }
    std::vector<std::size_t> due;
    for (std::size_t s : order) {
        if (!tracks[s]->initialised() || !usable[s]) continue;
        if (std::find(started.begin(), started.end(), s) == started.end()) due.push_back(s);
    }
    // Each deskew rebuilds its track's fine reference target: in parallel, the tracks are
    // independent (the re-anchoring below is not: it needs the root's first).
    std::vector<std::optional<Eigen::Isometry3d>> rights(due.size());
    const int threads = std::max(1, params.num_threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t k = 0; k < due.size(); ++k)
        rights[k] = tracks[due[k]]->deskew_reference(frame);
    bool any = false;
    std::vector<std::size_t> batch;  // re-anchored with the root's reference frame
    for (std::size_t k = 0; k < due.size(); ++k) {
        const std::size_t s = due[k];
        SensorTrack& track = *tracks[s];
        const auto& right = rights[k];
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
        window.remove_sensor(s);
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

void FusionEngine::Impl::add_fine_reference_edges(const std::vector<std::size_t>& fresh,
                                                  bool deskewed_only) {
    if (!(params.reference_voxel_size_m > 0) || fresh.empty()) return;
    const auto in_fresh = [&](std::size_t s) {
        return std::find(fresh.begin(), fresh.end(), s) != fresh.end();
    };
    std::vector<std::size_t> sensors;
    for (std::size_t s = 0; s < n; ++s) {
        const SensorTrack& t = *tracks[s];
        if (!t.initialised() || (deskewed_only && !t.reference_deskewed())) continue;
        bool shares = false;
        for (std::size_t f : fresh)
            shares = shares || tracks[f]->reference_frame() == t.reference_frame();
        if (in_fresh(s) || shares) sensors.push_back(s);
    }
    std::vector<FinePair> pairs = plan_fine_pairs(tracks, sensors, in_fresh);
    std::vector<GicpCloud> made(sensors.size());
    const std::vector<const GicpCloud*> targets = fine_targets(
        tracks, sensors, pairs, params.reference_voxel_size_m, params.num_threads, &made);
    pairs.erase(std::remove_if(pairs.begin(), pairs.end(),
                               [&targets](const FinePair& p) {
                                   return targets[p.a]->size() < 3 || targets[p.b]->size() < 3;
                               }),
                pairs.end());
    GicpParams g = params.gicp;
    g.max_correspondence_distance_m = params.correspondence_factor * params.reference_voxel_size_m;
    const int threads = std::max(1, params.num_threads);
    std::vector<GicpRegistration> fine(static_cast<std::size_t>(threads), GicpRegistration(g));
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::size_t k = 0; k < pairs.size(); ++k) {
        auto& pair = pairs[k];
        pair.result = fine[static_cast<std::size_t>(omp_get_thread_num())].align(
            *targets[pair.a], *targets[pair.b], pair.T_init);
    }
    for (const auto& pair : pairs) {
        const auto& r = pair.result;
        if (!r.converged && r.status != GicpStatus::kMaxIterations) continue;
        if (r.inlier_ratio < 0.5 * params.min_fitness) continue;
        const std::size_t sa = sensors[pair.a], sb = sensors[pair.b];
        const auto e = graph.add_edge(node_id(sa, tracks[sa]->reference_frame()),
                                      node_id(sb, tracks[sb]->reference_frame()), r.T_target_source,
                                      calibrated_information(r));
        if (e >= 0) reference_edges.push_back({e, sa, sb});
    }
}

}  // namespace lidarfuse::core
