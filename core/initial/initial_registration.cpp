#include "core/initial/initial_registration.hpp"

#include <algorithm>

#include "core/common/se3.hpp"
#include "core/common/stopwatch.hpp"
#include "core/initial/edge_consensus.hpp"

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
                                           const InitialRegistrationParams& params) {
    const Stopwatch whole;
    InitialRegistrationResult result;
    const std::size_t n = clouds.size();
    const int threads = std::max(1, params.num_threads);
    result.sensors.resize(n);
    if (n == 0) return result;

    const auto cancelled = [&] {
        return params.cancel != nullptr && params.cancel->load(std::memory_order_acquire);
    };
    // One report at a time: the callback need not be thread-safe.
    const auto report = [&](const char* stage, std::size_t done, std::size_t total) {
        if (!params.on_progress) return;
#pragma omp critical(lidarfuse_initial_registration_progress)
        params.on_progress(stage, done, total);
    };
    // A cancelled run registers nothing (never a half-checked pose).
    const auto give_up = [&] {
        for (SensorRegistration& sr : result.sensors) {
            sr.registered = false;
            sr.status = SensorRegistrationStatus::kCancelled;
            sr.T_root_sensor = Eigen::Isometry3d::Identity();
        }
        result.timings.total_s = whole.seconds();
        return result;
    };

    // Steps 2-4 per sensor, sensors in parallel.
    Stopwatch stage;
    std::vector<SensorFeatures> features(n);
    std::atomic<std::size_t> done{0};
    report("features", 0, n);
    {
        const int outer = std::min<int>(threads, static_cast<int>(n));
        SensorFeatureParams feature_params = params.features;
        feature_params.num_threads = std::max(1, threads / outer);
#pragma omp parallel for num_threads(outer) schedule(dynamic, 1)
        for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) {
            if (cancelled()) continue;
            features[i] = compute_sensor_features(clouds[i], feature_params, params.min_keypoints);
            report("features", ++done, n);
        }
    }
    result.timings.features_s = stage.seconds();
    if (cancelled()) return give_up();

    // Steps 5-8 for every pair i > j, pairs in parallel.
    stage.restart();
    for (std::size_t i = 1; i < n; ++i) {
        for (std::size_t j = 0; j < i; ++j) {
            PairResult pair;
            pair.source = static_cast<int>(i);
            pair.target = static_cast<int>(j);
            result.pairs.push_back(pair);
        }
    }
    done = 0;
    report("pairs", 0, result.pairs.size());
    {
        const auto n_pairs = static_cast<std::int64_t>(result.pairs.size());
        const int outer =
            static_cast<int>(std::max<std::int64_t>(1, std::min<std::int64_t>(threads, n_pairs)));
        const int inner = std::max(1, threads / outer);
#pragma omp parallel for num_threads(outer) schedule(dynamic, 1)
        for (std::int64_t e = 0; e < n_pairs; ++e) {
            if (cancelled()) continue;
            const int i = result.pairs[e].source;
            const int j = result.pairs[e].target;
            result.pairs[e] = register_pair(features[i], features[j], i, j, params.pair, inner);
            report("pairs", ++done, result.pairs.size());
        }
    }
    result.timings.pairs_s = stage.seconds();
    if (cancelled()) return give_up();

    // Step 9: pose graph over the good pairs, root fixed; drop edges that break cycle
    // consistency, one at a time (the worst first), and solve again.
    report("pose graph", 0, 1);
    stage.restart();
    std::vector<bool> edge_ok(result.pairs.size());
    for (std::size_t e = 0; e < result.pairs.size(); ++e) {
        edge_ok[e] = result.pairs[e].status == PairStatus::kOk;
    }
    EdgeConsensusParams consensus = params.consensus;
    consensus.max_edge_translation_m = params.max_edge_translation_m;
    consensus.max_edge_rotation_deg = params.max_edge_rotation_deg;
    consensus.min_sensor_separation_m = params.pair.min_sensor_separation_m;
    const EdgeConsensusResult consensus_result =
        select_consistent_edges(n, &result.pairs, &edge_ok, consensus);
    const std::vector<bool>& ambiguous = consensus_result.ambiguous;
    const std::vector<bool>& unconfirmed = consensus_result.unconfirmed;
    std::vector<bool> refused(n, false);
    for (std::size_t i = 0; i < n; ++i) refused[i] = ambiguous[i] || unconfirmed[i];
    close_loops(features, refused, params, threads, &result.pairs, &edge_ok);
    result.timings.pose_graph_s = stage.seconds();

    stage.restart();
    EdgePolishParams polish = params.polish;
    polish.gicp = params.pair.gicp;
    polish.p2p_cutoff_m = params.pair.p2p_cutoff_m;
    result.polish = polish_edges(features, edge_ok, polish, &result.pairs, threads);
    result.timings.polish_s = stage.seconds();

    stage.restart();
    std::vector<Eigen::Isometry3d> poses;
    std::vector<bool> reached;
    while (true) {
        spanning_tree_poses(n, result.pairs, edge_ok, &poses, &reached);
        PoseGraphParams graph_params = params.pose_graph;
        graph_params.num_threads = threads;
        PoseGraph graph(graph_params);
        for (std::size_t i = 0; i < n; ++i) {
            if (reached[i]) graph.add_node(static_cast<PoseGraph::NodeId>(i), poses[i], i == 0);
        }
        std::vector<std::pair<std::size_t, PoseGraph::EdgeId>> edges;
        for (std::size_t e = 0; e < result.pairs.size(); ++e) {
            const PairResult& p = result.pairs[e];
            if (!edge_ok[e] || !reached[p.source] || !reached[p.target]) continue;
            const PoseGraph::EdgeId id =
                graph.add_edge(p.target, p.source, p.chosen.T_target_source, p.chosen.information);
            if (id < 0) {
                result.pairs[e].status = PairStatus::kDegenerate;
                edge_ok[e] = false;
                continue;
            }
            edges.emplace_back(e, id);
        }
        if (edges.empty()) break;
        result.pose_graph = graph.optimize();
        if (!result.pose_graph.usable) break;  // keep the spanning-tree poses
        std::size_t worst = result.pairs.size();
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
        if (worst == result.pairs.size()) {
            for (std::size_t i = 0; i < n; ++i) {
                if (reached[i])
                    poses[i] = orthonormalized(*graph.node_pose(static_cast<PoseGraph::NodeId>(i)));
            }
            break;
        }
        result.pairs[worst].status = PairStatus::kRejectedByPoseGraph;
        edge_ok[worst] = false;
    }
    result.timings.pose_graph_s += stage.seconds();

    // Per-sensor outcome, with the reason when unregistered.
    for (std::size_t i = 0; i < n; ++i) {
        SensorRegistration& s = result.sensors[i];
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
            continue;
        }
        if (f.status != SensorFeatureStatus::kOk) {
            s.status = from_features(f.status);
            continue;
        }
        if (reached[i]) {
            s.registered = true;
            s.status = SensorRegistrationStatus::kRegistered;
            s.T_root_sensor = poses[i];
            continue;
        }
        // A pair that failed for weak constraints is a failed match too: the sensor's own
        // degeneracy (plane only) was ruled out by its features.
        bool any_ok = false;
        for (std::size_t e = 0; e < result.pairs.size(); ++e) {
            const PairResult& p = result.pairs[e];
            if (p.source != static_cast<int>(i) && p.target != static_cast<int>(i)) continue;
            any_ok = any_ok || edge_ok[e];
        }
        s.status = ambiguous[i]     ? SensorRegistrationStatus::kAmbiguous
                   : unconfirmed[i] ? SensorRegistrationStatus::kUnconfirmed
                   : any_ok         ? SensorRegistrationStatus::kNotConnectedToRoot
                                    : SensorRegistrationStatus::kNoConsistentCorrespondences;
    }
    result.timings.total_s = whole.seconds();
    return result;
}

}  // namespace lidarfuse::core
