#include "core/initial/edge_consensus.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "core/common/se3.hpp"

namespace lidarfuse::core {

namespace {

struct Option {
    std::size_t pair;
    PairAlternative estimate;
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

// A sampled spanning tree: its poses and, per pair, the option consistent with them.
struct Tree {
    Score score;
    std::vector<Eigen::Isometry3d> poses;
    std::vector<bool> has;
    std::vector<int> pick;  // per pair index; -1 when none is consistent (or not good)
};

// EdgeConsensusParams::min_bridge_information_per_inlier: for each weak consistent pair of
// the winning tree, the sensors that lose their link to the root (sensor 0) without it.
void mark_beyond_weak_bridges(std::size_t n, const std::vector<PairResult>& pairs,
                              const std::vector<std::size_t>& good,
                              const std::vector<Option>& options, const Tree& winner,
                              const EdgeConsensusParams& params, std::vector<bool>* unconfirmed) {
    std::vector<std::size_t> consistent;
    for (std::size_t e : good) {
        if (winner.pick[e] >= 0) consistent.push_back(e);
    }
    for (std::size_t weak : consistent) {
        const PairAlternative& a = options[static_cast<std::size_t>(winner.pick[weak])].estimate;
        if (information_per_inlier(a.min_hessian_eigenvalue, a.gicp_inliers) >=
            params.min_bridge_information_per_inlier) {
            continue;
        }
        // Reach from the root over the other consistent pairs.
        std::vector<bool> reach(n, false);
        reach[0] = true;
        for (bool grew = true; grew;) {
            grew = false;
            for (std::size_t e : consistent) {
                if (e == weak) continue;
                const auto s = static_cast<std::size_t>(pairs[e].source);
                const auto t = static_cast<std::size_t>(pairs[e].target);
                if (reach[s] != reach[t]) {
                    reach[s] = reach[t] = true;
                    grew = true;
                }
            }
        }
        for (std::size_t i = 0; i < n; ++i) {
            if (winner.has[i] && !reach[i]) (*unconfirmed)[i] = true;
        }
    }
}

// -1: a is worse beyond the tolerance, +1: better by the margin, 0: neither.
int compare_larger_is_better(double a, double b, double share) {
    if (a < (1.0 - share) * b) return -1;
    if (b < (1.0 - share) * a) return 1;
    return 0;
}

}  // namespace

bool clearly_better(const PairAlternative& a, const PairAlternative& b,
                    const AmbiguityParams& params) {
    const auto support_a = static_cast<double>(a.p2p_inliers);
    const auto support_b = static_cast<double>(b.p2p_inliers);
    if (support_b < params.min_support_share * support_a) return true;
    if (support_a < params.min_support_share * support_b) return false;
    const int support = compare_larger_is_better(support_a, support_b, params.support_share);
    // Smaller is better: compare the other way round.
    const int error = compare_larger_is_better(b.p2p_error_m, a.p2p_error_m, params.error_share);
    const double fs_difference = b.free_space_violation_share - a.free_space_violation_share;
    const int free_space = fs_difference >= params.free_space_share    ? 1
                           : fs_difference <= -params.free_space_share ? -1
                                                                       : 0;
    const bool worse_somewhere = support < 0 || error < 0 || free_space < 0;
    const bool better_somewhere = support > 0 || error > 0 || free_space > 0;
    return !worse_somewhere && better_somewhere;
}

EdgeConsensusResult select_consistent_edges(std::size_t n, std::vector<PairResult>* pairs,
                                            std::vector<bool>* edge_ok,
                                            const EdgeConsensusParams& params) {
    EdgeConsensusResult result;
    result.ambiguous.assign(n, false);
    result.unconfirmed.assign(n, false);
    std::vector<Option> options;
    std::vector<std::size_t> good;
    for (std::size_t e = 0; e < pairs->size(); ++e) {
        if (!(*edge_ok)[e]) continue;
        good.push_back(e);
        options.push_back({e, (*pairs)[e].chosen});
    }
    std::stable_sort(options.begin(), options.end(), [](const Option& a, const Option& b) {
        return a.estimate.p2p_inliers > b.estimate.p2p_inliers;
    });
    for (std::size_t e : good) {
        for (const PairAlternative& a : (*pairs)[e].alternatives) options.push_back({e, a});
    }
    if (good.empty() || n == 0) return result;

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
    // Sensors two trees place differently (or only one of them reaches).
    auto differing_sensors = [&](const Tree& a, const Tree& b) {
        std::vector<bool> differ(n, false);
        for (std::size_t i = 0; i < n; ++i) {
            if (a.has[i] != b.has[i]) {
                differ[i] = true;
            } else if (a.has[i]) {
                differ[i] =
                    translation_error_m(a.poses[i], b.poses[i]) > params.max_edge_translation_m ||
                    rotation_error_deg(a.poses[i], b.poses[i]) > params.max_edge_rotation_deg;
            }
        }
        return differ;
    };

    std::mt19937 rng(params.seed);
    std::vector<std::size_t> order(options.size());
    std::iota(order.begin(), order.end(), 0);
    std::vector<Tree> trees;  // valid and distinct
    std::size_t best = 0;
    for (int sample = 0; sample < params.samples; ++sample) {
        if (sample > 0) std::shuffle(order.begin(), order.end(), rng);
        // Tree: repeatedly take the first option (in `order`) that reaches a new sensor.
        Tree tree;
        tree.poses.assign(n, Eigen::Isometry3d::Identity());
        tree.has.assign(n, false);
        tree.has[0] = true;
        for (bool grew = true; grew;) {
            grew = false;
            for (std::size_t k : order) {
                const PairResult& p = (*pairs)[options[k].pair];
                const Eigen::Isometry3d& T = options[k].estimate.T_target_source;
                if (tree.has[p.source] == tree.has[p.target]) continue;
                if (tree.has[p.target]) {
                    tree.poses[p.source] = tree.poses[p.target] * T;
                    tree.has[p.source] = true;
                } else {
                    tree.poses[p.target] = tree.poses[p.source] * T.inverse();
                    tree.has[p.target] = true;
                }
                grew = true;
                break;
            }
        }
        bool valid = true;
        for (std::size_t a = 0; a < n && valid; ++a) {
            for (std::size_t b = a + 1; b < n && valid; ++b) {
                valid = !(tree.has[a] && tree.has[b] &&
                          (tree.poses[a].translation() - tree.poses[b].translation()).norm() <
                              params.min_sensor_separation_m);
            }
        }
        if (!valid) continue;
        tree.score.consistent = 0;
        tree.pick.assign(pairs->size(), -1);
        for (std::size_t i = 0; i < n; ++i) tree.score.reached += tree.has[i] ? 1 : 0;
        for (std::size_t e : good) {
            const int k = consistent_option(e, tree.poses, tree.has);
            tree.pick[e] = k;
            if (k < 0) continue;
            ++tree.score.consistent;
            tree.score.support += options[k].estimate.p2p_inliers;
        }
        bool duplicate = false;
        for (const Tree& t : trees) {
            const std::vector<bool> differ = differing_sensors(t, tree);
            duplicate =
                duplicate || std::none_of(differ.begin(), differ.end(), [](bool d) { return d; });
        }
        if (duplicate) continue;
        trees.push_back(std::move(tree));
        if (trees.size() == 1 || trees.back().score > trees[best].score) best = trees.size() - 1;
    }

    // `a` clearly beats `b` on the pairs where they use different candidates, their
    // figures pooled: support summed, p2p error as the support-weighted RMS, free-space
    // violation shares summed (each pair is one more independent look at the same
    // placements; with one differing pair this is clearly_better on that pair).
    auto pooled = [&](const Tree& t, const Tree& other) {
        PairAlternative sum;
        double weighted_sq_error = 0.0;
        for (std::size_t e : good) {
            if (t.pick[e] == other.pick[e] || t.pick[e] < 0) continue;
            const PairAlternative& o = options[t.pick[e]].estimate;
            sum.p2p_inliers += o.p2p_inliers;
            weighted_sq_error += static_cast<double>(o.p2p_inliers) * o.p2p_error_m * o.p2p_error_m;
            sum.free_space_violation_share += o.free_space_violation_share;
        }
        if (sum.p2p_inliers > 0)
            sum.p2p_error_m = std::sqrt(weighted_sq_error / static_cast<double>(sum.p2p_inliers));
        return sum;
    };
    auto tree_clearly_better = [&](const Tree& a, const Tree& b) {
        return clearly_better(pooled(a, b), pooled(b, a), params.ambiguity);
    };
    auto rivals = [&](const Tree& a, const Tree& b) {
        return &a != &b && a.score.consistent == b.score.consistent &&
               a.score.reached == b.score.reached;
    };
    if (params.ambiguity.enabled && !trees.empty()) {
        // A rival clearly better than the winner takes its place (bounded: the relation
        // has no cycles in practice, but the loop must end regardless).
        for (std::size_t pass = 0; pass < trees.size(); ++pass) {
            bool replaced = false;
            for (std::size_t t = 0; t < trees.size() && !replaced; ++t) {
                if (rivals(trees[t], trees[best]) && tree_clearly_better(trees[t], trees[best])) {
                    best = t;
                    replaced = true;
                }
            }
            if (!replaced) break;
        }
        for (const Tree& t : trees) {
            if (!rivals(t, trees[best])) continue;
            ++result.rival_trees;
            if (tree_clearly_better(trees[best], t)) continue;
            const std::vector<bool> differ = differing_sensors(trees[best], t);
            for (std::size_t i = 0; i < n; ++i)
                result.ambiguous[i] = result.ambiguous[i] || differ[i];
        }
    }

    if (!trees.empty() && params.min_bridge_information_per_inlier > 0) {
        mark_beyond_weak_bridges(n, *pairs, good, options, trees[best], params,
                                 &result.unconfirmed);
    }

    for (std::size_t e : good) {
        PairResult& p = (*pairs)[e];
        if (result.ambiguous[p.source] || result.ambiguous[p.target]) {
            p.status = PairStatus::kAmbiguous;
            (*edge_ok)[e] = false;
            continue;
        }
        if (result.unconfirmed[p.source] || result.unconfirmed[p.target]) {
            p.status = PairStatus::kUnconfirmed;
            (*edge_ok)[e] = false;
            continue;
        }
        const int k = trees.empty() ? -1 : trees[best].pick[e];
        if (k < 0) {
            p.status = PairStatus::kRejectedByPoseGraph;
            (*edge_ok)[e] = false;
            continue;
        }
        const PairAlternative pick = options[k].estimate;
        if (pick.candidate != p.chosen.candidate) {
            std::vector<PairAlternative> others{p.chosen};
            for (const PairAlternative& a : p.alternatives) {
                if (a.candidate != pick.candidate) others.push_back(a);
            }
            p.chosen = pick;
            p.alternatives = std::move(others);
        }
    }
    return result;
}

}  // namespace lidarfuse::core
