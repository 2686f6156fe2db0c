#include "core/initial_registration.hpp"

#include <algorithm>
#include <chrono>
#include <numeric>
#include <random>

#include "core/se3.hpp"

namespace lidarfuse::core {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

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
            if (best == nullptr || p.p2p_inliers > best->p2p_inliers) best = &p;
        }
        if (best == nullptr) return;
        if ((*has)[best->target]) {
            (*poses)[best->source] = (*poses)[best->target] * best->T_target_source;
            (*has)[best->source] = true;
        } else {
            (*poses)[best->target] = (*poses)[best->source] * best->T_target_source.inverse();
            (*has)[best->target] = true;
        }
    }
}

// Our addition: the largest mutually consistent set of pairwise results. On a symmetric
// site a pair can pass every pairwise check with a look-alike (the intersection's arms),
// even with a lower p2p error than the right candidate, and the worst-residual-first
// pruning of the pose graph may then keep look-alikes that agree with each other. So
// spanning trees are sampled (seeded; the max-support tree of the chosen candidates
// first) over every pair's chosen candidate and its alternatives (one per pair), each tree
// gives poses, and a tree is invalid when it puts two sensors within
// min_sensor_separation_m of each other (two sensors cannot share a place; a look-alike
// typically puts a sensor onto another's position). The valid tree under which the most
// pairs have a consistent candidate wins (ties: more sensors reached, then more p2p
// support); each pair keeps its consistent candidate, pairs without one are dropped.
void keep_consistent_edges(std::size_t n, std::vector<PairResult>* pairs, std::vector<bool>* edge_ok,
                           const InitialRegistrationParams& params) {
    struct Option {
        std::size_t pair;
        PairAlternative estimate;
    };
    std::vector<Option> options;
    std::vector<std::size_t> good;
    for (std::size_t e = 0; e < pairs->size(); ++e) {
        if (!(*edge_ok)[e]) continue;
        good.push_back(e);
        options.push_back({e, (*pairs)[e].chosen()});
    }
    std::stable_sort(options.begin(), options.end(), [](const Option& a, const Option& b) {
        return a.estimate.p2p_inliers > b.estimate.p2p_inliers;
    });
    for (std::size_t e : good) {
        for (const PairAlternative& a : (*pairs)[e].alternatives) options.push_back({e, a});
    }
    if (good.empty()) return;
    // Index of the first option of a pair consistent with `poses`, or -1.
    auto consistent_option = [&](std::size_t e, const std::vector<Eigen::Isometry3d>& poses,
                                 const std::vector<bool>& has) -> int {
        const PairResult& p = (*pairs)[e];
        if (!has[p.source] || !has[p.target]) return -1;
        const Eigen::Isometry3d implied = poses[p.target].inverse() * poses[p.source];
        for (std::size_t k = 0; k < options.size(); ++k) {
            if (options[k].pair != e) continue;
            const Eigen::Isometry3d& T = options[k].estimate.T_target_source;
            if (translation_error_m(implied, T) <= params.max_edge_translation_m &&
                rotation_error_deg(implied, T) <= params.max_edge_rotation_deg) {
                return static_cast<int>(k);
            }
        }
        return -1;
    };
    struct Score {
        int consistent = -1;
        int reached = 0;
        std::size_t support = 0;
        bool operator>(const Score& o) const {
            if (consistent != o.consistent) return consistent > o.consistent;
            if (reached != o.reached) return reached > o.reached;
            return support > o.support;
        }
    };
    std::mt19937 rng(params.consensus_seed);
    std::vector<std::size_t> order(options.size());
    std::iota(order.begin(), order.end(), 0);
    Score best;
    std::vector<Eigen::Isometry3d> best_poses;
    std::vector<bool> best_has;
    for (int sample = 0; sample < params.consensus_samples; ++sample) {
        if (sample > 0) std::shuffle(order.begin(), order.end(), rng);
        // Tree: repeatedly take the first option (in `order`) that reaches a new sensor.
        std::vector<Eigen::Isometry3d> poses(n, Eigen::Isometry3d::Identity());
        std::vector<bool> has(n, false);
        has[0] = true;
        for (bool grew = true; grew;) {
            grew = false;
            for (std::size_t k : order) {
                const PairResult& p = (*pairs)[options[k].pair];
                const Eigen::Isometry3d& T = options[k].estimate.T_target_source;
                if (has[p.source] == has[p.target]) continue;
                if (has[p.target]) {
                    poses[p.source] = poses[p.target] * T;
                    has[p.source] = true;
                } else {
                    poses[p.target] = poses[p.source] * T.inverse();
                    has[p.target] = true;
                }
                grew = true;
                break;
            }
        }
        bool valid = true;
        for (std::size_t a = 0; a < n && valid; ++a) {
            for (std::size_t b = a + 1; b < n && valid; ++b) {
                valid = !(has[a] && has[b] &&
                          (poses[a].translation() - poses[b].translation()).norm() <
                              params.pair.min_sensor_separation_m);
            }
        }
        if (!valid) continue;
        Score score;
        score.consistent = 0;
        for (std::size_t i = 0; i < n; ++i) score.reached += has[i] ? 1 : 0;
        for (std::size_t e : good) {
            const int k = consistent_option(e, poses, has);
            if (k < 0) continue;
            ++score.consistent;
            score.support += options[k].estimate.p2p_inliers;
        }
        if (score > best) {
            best = score;
            best_poses = poses;
            best_has = has;
        }
    }
    for (std::size_t e : good) {
        PairResult& p = (*pairs)[e];
        const int k = best.consistent >= 0 ? consistent_option(e, best_poses, best_has) : -1;
        if (k < 0) {
            p.status = PairStatus::kRejectedByPoseGraph;
            (*edge_ok)[e] = false;
            continue;
        }
        const PairAlternative pick = options[k].estimate;
        if (pick.candidate != p.chosen_candidate) {
            std::vector<PairAlternative> others{p.chosen()};
            for (const PairAlternative& a : p.alternatives) {
                if (a.candidate != pick.candidate) others.push_back(a);
            }
            p.choose(pick);
            p.alternatives = std::move(others);
        }
    }
}

SensorRegistrationStatus from_features(SensorFeatureStatus status) {
    switch (status) {
        case SensorFeatureStatus::kOk: return SensorRegistrationStatus::kRegistered;
        case SensorFeatureStatus::kEmptyCloud: return SensorRegistrationStatus::kEmptyCloud;
        case SensorFeatureStatus::kPlaneOnly: return SensorRegistrationStatus::kDegenerate;
        case SensorFeatureStatus::kTooFewKeypoints: return SensorRegistrationStatus::kTooFewKeypoints;
    }
    return SensorRegistrationStatus::kEmptyCloud;
}

}  // namespace

const char* to_string(SensorRegistrationStatus status) {
    switch (status) {
        case SensorRegistrationStatus::kRegistered: return "registered";
        case SensorRegistrationStatus::kEmptyCloud: return "empty cloud";
        case SensorRegistrationStatus::kTooFewKeypoints: return "too few keypoints";
        case SensorRegistrationStatus::kDegenerate: return "degenerate: plane only";
        case SensorRegistrationStatus::kNoConsistentCorrespondences: return "no consistent correspondences";
        case SensorRegistrationStatus::kCancelled: return "cancelled";
        case SensorRegistrationStatus::kNotConnectedToRoot: return "not connected to the root sensor";
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
    const auto start_total = Clock::now();
    InitialRegistrationResult result;
    const std::size_t n = clouds.size();
    const int threads = std::max(1, params.num_threads);
    result.sensors.resize(n);
    if (n == 0) return result;

    const auto cancelled = [&] {
        return params.cancel != nullptr && params.cancel->load(std::memory_order_acquire);
    };
    // A cancelled run registers nothing (never a half-checked pose).
    const auto give_up = [&] {
        for (SensorRegistration& sr : result.sensors) {
            sr.registered = false;
            sr.status = SensorRegistrationStatus::kCancelled;
            sr.T_root_sensor = Eigen::Isometry3d::Identity();
        }
        result.timings.total_s = seconds_since(start_total);
        return result;
    };

    // Steps 2-4 per sensor, sensors in parallel.
    auto start = Clock::now();
    std::vector<SensorFeatures> features(n);
    {
        const int outer = std::min<int>(threads, static_cast<int>(n));
        SensorFeatureParams feature_params = params.features;
        feature_params.num_threads = std::max(1, threads / outer);
#pragma omp parallel for num_threads(outer) schedule(dynamic, 1)
        for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) {
            if (cancelled()) continue;
            features[i] = compute_sensor_features(clouds[i], feature_params, params.min_keypoints);
        }
    }
    result.timings.features_s = seconds_since(start);
    if (cancelled()) return give_up();

    // Steps 5-8 for every pair i > j, pairs in parallel.
    start = Clock::now();
    for (std::size_t i = 1; i < n; ++i) {
        for (std::size_t j = 0; j < i; ++j) {
            PairResult pair;
            pair.source = static_cast<int>(i);
            pair.target = static_cast<int>(j);
            result.pairs.push_back(pair);
        }
    }
    {
        const auto n_pairs = static_cast<std::int64_t>(result.pairs.size());
        const int outer = static_cast<int>(std::max<std::int64_t>(1, std::min<std::int64_t>(threads, n_pairs)));
        PairRegistrationParams pair_params = params.pair;
        pair_params.num_threads = std::max(1, threads / outer);
#pragma omp parallel for num_threads(outer) schedule(dynamic, 1)
        for (std::int64_t e = 0; e < n_pairs; ++e) {
            if (cancelled()) continue;
            const int i = result.pairs[e].source;
            const int j = result.pairs[e].target;
            result.pairs[e] = register_pair(features[i], features[j], i, j, pair_params);
        }
    }
    result.timings.pairs_s = seconds_since(start);
    if (cancelled()) return give_up();

    // Step 9: pose graph over the good pairs, root fixed; drop edges that break cycle
    // consistency, one at a time (the worst first), and solve again.
    start = Clock::now();
    std::vector<bool> edge_ok(result.pairs.size());
    for (std::size_t e = 0; e < result.pairs.size(); ++e) {
        edge_ok[e] = result.pairs[e].status == PairStatus::kOk;
    }
    keep_consistent_edges(n, &result.pairs, &edge_ok, params);
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
                graph.add_edge(p.target, p.source, p.T_target_source, p.information);
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
                if (reached[i]) poses[i] = orthonormalized(*graph.node_pose(static_cast<PoseGraph::NodeId>(i)));
            }
            break;
        }
        result.pairs[worst].status = PairStatus::kRejectedByPoseGraph;
        edge_ok[worst] = false;
    }
    result.timings.pose_graph_s = seconds_since(start);

    // Per-sensor outcome, with the reason when unregistered.
    for (std::size_t i = 0; i < n; ++i) {
        SensorRegistration& s = result.sensors[i];
        const SensorFeatures& f = features[i];
        s.num_input_points = f.num_input_points;
        s.num_preprocessed_points = f.num_preprocessed_points;
        s.num_downsampled_points = f.octree.cloud.size();
        s.num_keypoints = f.keypoints.size();
        s.timings = f.timings;
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
        s.status = any_ok ? SensorRegistrationStatus::kNotConnectedToRoot
                          : SensorRegistrationStatus::kNoConsistentCorrespondences;
    }
    result.timings.total_s = seconds_since(start_total);
    return result;
}

}  // namespace lidarfuse::core
