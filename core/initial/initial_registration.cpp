#include "core/initial/initial_registration.hpp"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/common/se3.hpp"
#include "core/common/stopwatch.hpp"
#include "core/initial/edge_consensus.hpp"
#include "core/initial/station_registration.hpp"

namespace lidarfuse::core {

namespace {

// Poses of the sensors reachable from the root over the good pairs, by a maximum spanning
// tree (Prim, edge weight = p2p support): the pose graph's starting point. Unreached
// sensors get no entry (has[i] false).
void spanning_tree_poses(std::size_t n, const std::vector<PairResult>& pairs,
                         const std::vector<bool>& edge_ok, std::vector<Eigen::Isometry3d>* poses,
                         std::vector<bool>* has) {
    poses->assign(n, Eigen::Isometry3d::Identity());
    has->assign(n, false);
    if (n == 0) return;
    (*has)[0] = true;
    while (true) {
        const PairResult* best = nullptr;
        for (std::size_t e = 0; e < pairs.size(); ++e) {
            const PairResult& p = pairs[e];
            if (!edge_ok[e] || (*has)[p.source] == (*has)[p.target]) continue;
            if (best == nullptr || p.chosen.p2p_inliers > best->chosen.p2p_inliers) best = &p;
        }
        if (best == nullptr) return;
        if ((*has)[best->target]) {
            (*poses)[best->source] = (*poses)[best->target] * best->chosen.T_target_source;
            (*has)[best->source] = true;
        } else {
            (*poses)[best->target] =
                (*poses)[best->source] * best->chosen.T_target_source.inverse();
            (*has)[best->target] = true;
        }
    }
}

// Our addition, loop closure: a pair that kept no right candidate of its own (descriptors
// that match nothing between a dense and a sparse cloud, a vote with no peak) but whose two
// sensors the consensus placed through other pairs is refined from that placement with the
// same G-ICP and checks; it joins the pose graph when it stays within the edge tolerances
// of the placement. It adds a measurement, never a placement: both sensors are placed
// already, and a refused sensor (ambiguous, unconfirmed) is left alone.
void close_loops(const std::vector<SensorFeatures>& features, const std::vector<bool>& refused,
                 const InitialRegistrationParams& params, int threads,
                 std::vector<PairResult>* pairs, std::vector<bool>* edge_ok) {
    std::vector<Eigen::Isometry3d> poses;
    std::vector<bool> placed;
    spanning_tree_poses(features.size(), *pairs, *edge_ok, &poses, &placed);
    for (std::size_t e = 0; e < pairs->size(); ++e) {
        const PairResult& p = (*pairs)[e];
        const auto s = static_cast<std::size_t>(p.source);
        const auto t = static_cast<std::size_t>(p.target);
        if ((*edge_ok)[e] || !placed[s] || !placed[t] || refused[s] || refused[t]) continue;
        const Eigen::Isometry3d T_start = poses[t].inverse() * poses[s];
        PairRegistrationParams pair_params = params.pair;
        pair_params.start_T_target_source = &T_start;
        PairResult closed =
            register_pair(features[s], features[t], p.source, p.target, pair_params, threads);
        if (closed.status != PairStatus::kOk ||
            translation_error_m(closed.chosen.T_target_source, T_start) >
                params.max_edge_translation_m ||
            rotation_error_deg(closed.chosen.T_target_source, T_start) >
                params.max_edge_rotation_deg) {
            continue;
        }
        // Keep what the search tried, for the diagnostics, before the closing run.
        closed.timings = p.timings;
        closed.tried.insert(closed.tried.begin(), p.tried.begin(), p.tried.end());
        (*pairs)[e] = std::move(closed);
        (*edge_ok)[e] = true;
    }
}

SensorRegistrationStatus from_features(SensorFeatureStatus status) {
    switch (status) {
        case SensorFeatureStatus::kOk:
            return SensorRegistrationStatus::kRegistered;
        case SensorFeatureStatus::kEmptyCloud:
            return SensorRegistrationStatus::kEmptyCloud;
        case SensorFeatureStatus::kPlaneOnly:
            return SensorRegistrationStatus::kDegenerate;
        case SensorFeatureStatus::kTooFewKeypoints:
            return SensorRegistrationStatus::kTooFewKeypoints;
    }
    return SensorRegistrationStatus::kEmptyCloud;
}

// One report at a time: the callback need not be thread-safe.
void report_progress(const InitialRegistrationParams& params, const char* stage, std::size_t done,
                     std::size_t total) {
    if (!params.on_progress) return;
#pragma omp critical(lidarfuse_initial_registration_progress)
    params.on_progress(stage, done, total);
}

// A cancelled run registers nothing (never a half-checked pose).
InitialRegistrationResult cancelled(InitialRegistrationResult result, const Stopwatch& whole) {
    for (SensorRegistration& sr : result.sensors) {
        sr.registered = false;
        sr.status = SensorRegistrationStatus::kCancelled;
        sr.T_root_sensor = Eigen::Isometry3d::Identity();
    }
    result.timings.total_s = whole.seconds();
    return result;
}

// Steps 2-4 for every sensor, the sensors in parallel and the threads left over inside each.
// A cancelled run leaves the remaining sensors' features empty.
std::vector<SensorFeatures> compute_all_features(const std::vector<PointCloud>& clouds,
                                                 const InitialRegistrationParams& params,
                                                 int threads) {
    const std::size_t n = clouds.size();
    std::vector<SensorFeatures> features(n);
    std::atomic<std::size_t> done{0};
    report_progress(params, "features", 0, n);
    const int outer = std::min<int>(threads, static_cast<int>(n));
    const int inner = std::max(1, threads / outer);
#pragma omp parallel for num_threads(outer) schedule(dynamic, 1)
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) {
        if (params.cancel_requested()) continue;
        features[i] =
            compute_sensor_features(clouds[i], params.features, params.min_keypoints, inner);
        report_progress(params, "features", ++done, n);
    }
    return features;
}

// Steps 5-8 for every pair i > j, in the order (1,0), (2,0), (2,1), ..., the pairs in
// parallel. A cancelled run leaves the remaining pairs unregistered.
std::vector<PairResult> register_all_pairs(const std::vector<SensorFeatures>& features,
                                           const InitialRegistrationParams& params, int threads) {
    std::vector<PairResult> pairs;
    for (std::size_t i = 1; i < features.size(); ++i) {
        for (std::size_t j = 0; j < i; ++j) {
            PairResult pair;
            pair.source = static_cast<int>(i);
            pair.target = static_cast<int>(j);
            pairs.push_back(pair);
        }
    }
    std::atomic<std::size_t> done{0};
    report_progress(params, "pairs", 0, pairs.size());
    const auto n_pairs = static_cast<std::int64_t>(pairs.size());
    const int outer =
        static_cast<int>(std::max<std::int64_t>(1, std::min<std::int64_t>(threads, n_pairs)));
    const int inner = std::max(1, threads / outer);
#pragma omp parallel for num_threads(outer) schedule(dynamic, 1)
    for (std::int64_t e = 0; e < n_pairs; ++e) {
        if (params.cancel_requested()) continue;
        const int i = pairs[e].source;
        const int j = pairs[e].target;
        pairs[e] = register_pair(features[i], features[j], i, j, params.pair, inner);
        report_progress(params, "pairs", ++done, pairs.size());
    }
    return pairs;
}

// Which pairs the pose graph may use, and the sensors the consensus refused a pose.
struct EdgeSelection {
    std::vector<bool> ok;           // per pair
    std::vector<bool> ambiguous;    // per sensor (EdgeConsensusResult)
    std::vector<bool> unconfirmed;  // per sensor (EdgeConsensusResult)
};

// The good pairs, narrowed by the consensus over spanning trees, then widened by the loop
// closures between sensors it placed.
EdgeSelection select_edges(const std::vector<SensorFeatures>& features,
                           const InitialRegistrationParams& params, int threads,
                           std::vector<PairResult>* pairs) {
    const std::size_t n = features.size();
    EdgeSelection selection;
    selection.ok.resize(pairs->size());
    for (std::size_t e = 0; e < pairs->size(); ++e) {
        selection.ok[e] = (*pairs)[e].status == PairStatus::kOk;
    }
    EdgeConsensusParams consensus = params.consensus;
    consensus.max_edge_translation_m = params.max_edge_translation_m;
    consensus.max_edge_rotation_deg = params.max_edge_rotation_deg;
    consensus.min_sensor_separation_m = params.pair.min_sensor_separation_m;
    EdgeConsensusResult consensus_result =
        select_consistent_edges(n, pairs, &selection.ok, consensus);
    selection.ambiguous = std::move(consensus_result.ambiguous);
    selection.unconfirmed = std::move(consensus_result.unconfirmed);
    std::vector<bool> refused(n, false);
    for (std::size_t i = 0; i < n; ++i) {
        refused[i] = selection.ambiguous[i] || selection.unconfirmed[i];
    }
    close_loops(features, refused, params, threads, pairs, &selection.ok);
    return selection;
}

// The last, tighter G-ICP run on the kept pairs, with the pair stage's G-ICP and r_c.
EdgePolishSummary polish_kept_edges(const std::vector<SensorFeatures>& features,
                                    const std::vector<bool>& edge_ok,
                                    const InitialRegistrationParams& params, int threads,
                                    std::vector<PairResult>* pairs) {
    EdgePolishParams polish = params.polish;
    polish.gicp = params.pair.gicp;
    polish.p2p_cutoff_m = params.pair.p2p_cutoff_m;
    return polish_edges(features, edge_ok, polish, pairs, threads);
}

// T_root_sensor per sensor and whether the root reaches it (has no pose otherwise).
struct GraphPoses {
    std::vector<Eigen::Isometry3d> poses;
    std::vector<bool> reached;
};

// The pose graph's edges: (pair index, edge id).
using GraphEdges = std::vector<std::pair<std::size_t, PoseGraph::EdgeId>>;

// A node per reached sensor at its spanning-tree pose (the root fixed) and an edge per
// usable pair between them. A pair whose information the graph refuses is dropped as
// degenerate.
GraphEdges build_pose_graph(const GraphPoses& tree, std::vector<PairResult>* pairs,
                            std::vector<bool>* edge_ok, PoseGraph* graph) {
    for (std::size_t i = 0; i < tree.reached.size(); ++i) {
        if (tree.reached[i])
            graph->add_node(static_cast<PoseGraph::NodeId>(i), tree.poses[i], i == 0);
    }
    GraphEdges edges;
    for (std::size_t e = 0; e < pairs->size(); ++e) {
        const PairResult& p = (*pairs)[e];
        if (!(*edge_ok)[e] || !tree.reached[p.source] || !tree.reached[p.target]) continue;
        const PoseGraph::EdgeId id =
            graph->add_edge(p.target, p.source, p.chosen.T_target_source, p.chosen.information);
        if (id < 0) {
            (*pairs)[e].status = PairStatus::kDegenerate;
            (*edge_ok)[e] = false;
            continue;
        }
        edges.emplace_back(e, id);
    }
    return edges;
}

// The pair whose solved residual exceeds the edge tolerances the most, or num_pairs when
// every edge is within them.
std::size_t worst_edge(const PoseGraph& graph, const GraphEdges& edges, std::size_t num_pairs,
                       const InitialRegistrationParams& params) {
    std::size_t worst = num_pairs;
    double worst_excess = 1.0;
    for (const auto& [e, id] : edges) {
        const auto residual = graph.edge_residual(id);
        if (!residual) continue;
        const double excess = std::max(residual->translation_m / params.max_edge_translation_m,
                                       residual->rotation_deg / params.max_edge_rotation_deg);
        if (excess > worst_excess) {
            worst_excess = excess;
            worst = e;
        }
    }
    return worst;
}

// Solves the graph over the usable pairs and drops the worst edge beyond the tolerances
// until none is left; the solved poses, or the spanning tree's when no solve is usable.
GraphPoses solve_pose_graph(std::size_t n, const InitialRegistrationParams& params, int threads,
                            std::vector<PairResult>* pairs, std::vector<bool>* edge_ok,
                            PoseGraphSummary* summary) {
    GraphPoses tree;
    while (true) {
        spanning_tree_poses(n, *pairs, *edge_ok, &tree.poses, &tree.reached);
        PoseGraph graph(params.pose_graph);
        const GraphEdges edges = build_pose_graph(tree, pairs, edge_ok, &graph);
        if (edges.empty()) break;
        *summary = graph.optimize(threads);
        if (!summary->usable) break;  // keep the spanning-tree poses
        const std::size_t worst = worst_edge(graph, edges, pairs->size(), params);
        if (worst == pairs->size()) {
            for (std::size_t i = 0; i < n; ++i) {
                if (tree.reached[i]) {
                    tree.poses[i] =
                        orthonormalized(*graph.node_pose(static_cast<PoseGraph::NodeId>(i)));
                }
            }
            break;
        }
        (*pairs)[worst].status = PairStatus::kRejectedByPoseGraph;
        (*edge_ok)[worst] = false;
    }
    return tree;
}

// Why a sensor with good features got no pose.
SensorRegistrationStatus unreached_status(std::size_t i, const std::vector<PairResult>& pairs,
                                          const EdgeSelection& edges) {
    // A pair that failed for weak constraints is a failed match too: the sensor's own
    // degeneracy (plane only) was ruled out by its features.
    bool any_ok = false;
    for (std::size_t e = 0; e < pairs.size(); ++e) {
        const PairResult& p = pairs[e];
        if (p.source != static_cast<int>(i) && p.target != static_cast<int>(i)) continue;
        any_ok = any_ok || edges.ok[e];
    }
    return edges.ambiguous[i]     ? SensorRegistrationStatus::kAmbiguous
           : edges.unconfirmed[i] ? SensorRegistrationStatus::kUnconfirmed
           : any_ok               ? SensorRegistrationStatus::kNotConnectedToRoot
                                  : SensorRegistrationStatus::kNoConsistentCorrespondences;
}

// Per-sensor outcome: its feature figures, and its pose or the reason it has none.
void set_sensor_outcomes(const std::vector<SensorFeatures>& features,
                         const std::vector<PairResult>& pairs, const EdgeSelection& edges,
                         const GraphPoses& graph, std::vector<SensorRegistration>* sensors) {
    for (std::size_t i = 0; i < sensors->size(); ++i) {
        SensorRegistration& s = (*sensors)[i];
        const SensorFeatures& f = features[i];
        s.num_input_points = f.num_input_points;
        s.num_preprocessed_points = f.num_preprocessed_points;
        s.num_downsampled_points = f.octree.cloud.size();
        s.num_keypoints = f.keypoints.size();
        s.timings = f.timings;
        s.ground = f.ground;
        if (i == 0 && f.status == SensorFeatureStatus::kOk) {
            s.registered = true;  // the root defines the frame
            s.status = SensorRegistrationStatus::kRegistered;
        } else if (f.status != SensorFeatureStatus::kOk) {
            s.status = from_features(f.status);
        } else if (graph.reached[i]) {
            s.registered = true;
            s.status = SensorRegistrationStatus::kRegistered;
            s.T_root_sensor = graph.poses[i];
        } else {
            s.status = unreached_status(i, pairs, edges);
        }
    }
}

}  // namespace

const char* to_string(SensorRegistrationStatus status) {
    switch (status) {
        case SensorRegistrationStatus::kRegistered:
            return "registered";
        case SensorRegistrationStatus::kEmptyCloud:
            return "empty cloud";
        case SensorRegistrationStatus::kTooFewKeypoints:
            return "too few keypoints";
        case SensorRegistrationStatus::kDegenerate:
            return "degenerate: plane only";
        case SensorRegistrationStatus::kNoConsistentCorrespondences:
            return "no consistent correspondences";
        case SensorRegistrationStatus::kCancelled:
            return "cancelled";
        case SensorRegistrationStatus::kNotConnectedToRoot:
            return "not connected to the root sensor";
        case SensorRegistrationStatus::kAmbiguous:
            return "ambiguous: a look-alike placement fits as well";
        case SensorRegistrationStatus::kUnconfirmed:
            return "unconfirmed: one weak match, and no other sensor confirms it";
    }
    return "unknown";
}

std::size_t InitialRegistrationResult::num_registered() const {
    return static_cast<std::size_t>(std::count_if(
        sensors.begin(), sensors.end(), [](const SensorRegistration& s) { return s.registered; }));
}

InitialRegistrationParams default_initial_registration_params() {
    InitialRegistrationParams params;
    params.pair.p2p_cutoff_m = params.features.octree.max_voxel_size_m;
    return params;
}

StageTimeSums sum_stage_timings(const InitialRegistrationResult& result) {
    StageTimeSums sums;
    SensorFeatureTimings& f = sums.features;
    for (const SensorRegistration& s : result.sensors) {
        f.preprocess_s += s.timings.preprocess_s;
        f.normals_s += s.timings.normals_s;
        f.octree_s += s.timings.octree_s;
        f.keypoints_s += s.timings.keypoints_s;
        f.fpfh_s += s.timings.fpfh_s;
        f.ground_s += s.timings.ground_s;
        f.gicp_cloud_s += s.timings.gicp_cloud_s;
    }
    PairTimings& p = sums.pairs;
    for (const PairResult& pair : result.pairs) {
        p.matching_s += pair.timings.matching_s;
        p.ransac_s += pair.timings.ransac_s;
        p.gicp_s += pair.timings.gicp_s;
        p.p2p_s += pair.timings.p2p_s;
        p.ground_search_s += pair.timings.ground_search_s;
    }
    return sums;
}

InitialRegistrationResult register_initial(const std::vector<PointCloud>& clouds,
                                           const InitialRegistrationParams& params,
                                           int num_threads) {
    if (params.method == InitialRegistrationMethod::kStations) {
        return register_stations(clouds, params, num_threads);
    }
    const Stopwatch whole;
    InitialRegistrationResult result;
    const std::size_t n = clouds.size();
    const int threads = std::max(1, num_threads);
    result.sensors.resize(n);
    if (n == 0) return result;

    // Steps 2-4 per sensor, sensors in parallel.
    Stopwatch stage;
    const std::vector<SensorFeatures> features = compute_all_features(clouds, params, threads);
    result.timings.features_s = stage.seconds();
    if (params.cancel_requested()) return cancelled(std::move(result), whole);

    // Steps 5-8 for every pair i > j, pairs in parallel.
    stage.restart();
    result.pairs = register_all_pairs(features, params, threads);
    result.timings.pairs_s = stage.seconds();
    if (params.cancel_requested()) return cancelled(std::move(result), whole);

    // Step 9: pose graph over the good pairs, root fixed; drop edges that break cycle
    // consistency, one at a time (the worst first), and solve again.
    report_progress(params, "pose graph", 0, 1);
    stage.restart();
    EdgeSelection edges = select_edges(features, params, threads, &result.pairs);
    result.timings.pose_graph_s = stage.seconds();

    stage.restart();
    result.polish = polish_kept_edges(features, edges.ok, params, threads, &result.pairs);
    result.timings.polish_s = stage.seconds();

    stage.restart();
    const GraphPoses graph =
        solve_pose_graph(n, params, threads, &result.pairs, &edges.ok, &result.pose_graph);
    result.timings.pose_graph_s += stage.seconds();

    set_sensor_outcomes(features, result.pairs, edges, graph, &result.sensors);
    result.timings.total_s = whole.seconds();
    return result;
}

}  // namespace lidarfuse::core
