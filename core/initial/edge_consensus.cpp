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

// What a tree may use: per good pair (edge_ok) its chosen candidate, the most p2p support
// first (the first tree sampled is the max-support one), then every good pair's
// alternatives.
struct Candidates {
    std::vector<Option> options;
    std::vector<std::size_t> good;  // pair indices
};

Candidates collect_candidates(const std::vector<PairResult>& pairs,
                              const std::vector<bool>& edge_ok) {
    Candidates c;
    for (std::size_t e = 0; e < pairs.size(); ++e) {
        if (!edge_ok[e]) continue;
        c.good.push_back(e);
        c.options.push_back({e, pairs[e].chosen});
    }
    std::stable_sort(c.options.begin(), c.options.end(), [](const Option& a, const Option& b) {
        return a.estimate.p2p_inliers > b.estimate.p2p_inliers;
    });
    for (std::size_t e : c.good) {
        for (const PairAlternative& a : pairs[e].alternatives) c.options.push_back({e, a});
    }
    return c;
}

// Index of the first option of pair e consistent with the tree's poses, or -1.
int consistent_option(std::size_t e, const std::vector<PairResult>& pairs,
                      const std::vector<Option>& options, const Tree& tree,
                      const EdgeConsensusParams& params) {
    const PairResult& p = pairs[e];
    if (!tree.has[p.source] || !tree.has[p.target]) return -1;
    const Eigen::Isometry3d implied = tree.poses[p.target].inverse() * tree.poses[p.source];
    for (std::size_t k = 0; k < options.size(); ++k) {
        if (options[k].pair != e) continue;
        const Eigen::Isometry3d& T = options[k].estimate.T_target_source;
        if (translation_error_m(implied, T) <= params.max_edge_translation_m &&
            rotation_error_deg(implied, T) <= params.max_edge_rotation_deg) {
            return static_cast<int>(k);
        }
    }
    return -1;
}

// Sensors two trees place differently (or only one of them reaches).
std::vector<bool> differing_sensors(const Tree& a, const Tree& b,
                                    const EdgeConsensusParams& params) {
    const std::size_t n = a.has.size();
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
}

// The tree that repeatedly takes the first option (in `order`) that reaches a new sensor,
// from the root (sensor 0).
Tree grow_tree(std::size_t n, const std::vector<PairResult>& pairs,
               const std::vector<Option>& options, const std::vector<std::size_t>& order) {
    Tree tree;
    tree.poses.assign(n, Eigen::Isometry3d::Identity());
    tree.has.assign(n, false);
    tree.has[0] = true;
    for (bool grew = true; grew;) {
        grew = false;
        for (std::size_t k : order) {
            const PairResult& p = pairs[options[k].pair];
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
    return tree;
}

// A sensor other than `s` placed within min_sensor_separation_m of s, or the number of
// sensors when there is none.
std::size_t sensor_on(const Tree& tree, std::size_t s, const EdgeConsensusParams& params) {
    for (std::size_t u = 0; u < tree.has.size(); ++u) {
        if (u != s && tree.has[u] &&
            (tree.poses[u].translation() - tree.poses[s].translation()).norm() <
                params.min_sensor_separation_m) {
            return u;
        }
    }
    return tree.has.size();
}

// Invalid: the tree puts two sensors within min_sensor_separation_m of each other.
bool places_sensors_too_close(const Tree& tree, const EdgeConsensusParams& params) {
    for (std::size_t s = 0; s < tree.has.size(); ++s) {
        if (tree.has[s] && sensor_on(tree, s, params) != tree.has.size()) return true;
    }
    return false;
}

// The tree's score and, per good pair, its consistent option.
void score_tree(const std::vector<PairResult>& pairs, const Candidates& candidates,
                const EdgeConsensusParams& params, Tree* tree) {
    tree->score = Score{};
    tree->score.consistent = 0;
    tree->pick.assign(pairs.size(), -1);
    for (std::size_t i = 0; i < tree->has.size(); ++i) tree->score.reached += tree->has[i] ? 1 : 0;
    for (std::size_t e : candidates.good) {
        const int k = consistent_option(e, pairs, candidates.options, *tree, params);
        tree->pick[e] = k;
        if (k < 0) continue;
        ++tree->score.consistent;
        tree->score.support += candidates.options[k].estimate.p2p_inliers;
    }
}

// A tree that places every sensor as one already kept does.
bool duplicates_one_of(const std::vector<Tree>& trees, const Tree& tree,
                       const EdgeConsensusParams& params) {
    for (const Tree& t : trees) {
        const std::vector<bool> differ = differing_sensors(t, tree, params);
        if (std::none_of(differ.begin(), differ.end(), [](bool d) { return d; })) return true;
    }
    return false;
}

// The valid and distinct sampled trees, and the best of them by score.
struct SampledTrees {
    std::vector<Tree> trees;
    std::size_t best = 0;
};

// Scores `tree` and appends it when it is valid and new; true when it was appended.
bool keep_if_new(const std::vector<PairResult>& pairs, const Candidates& candidates,
                 const EdgeConsensusParams& params, Tree tree, SampledTrees* sampled) {
    if (places_sensors_too_close(tree, params)) return false;
    score_tree(pairs, candidates, params, &tree);
    if (duplicates_one_of(sampled->trees, tree, params)) return false;
    sampled->trees.push_back(std::move(tree));
    return true;
}

// Seeded: the first sample takes the options in their order, every later one shuffles the
// previous sample's order.
SampledTrees sample_trees(std::size_t n, const std::vector<PairResult>& pairs,
                          const Candidates& candidates, const EdgeConsensusParams& params) {
    SampledTrees sampled;
    std::mt19937 rng(params.seed);
    std::vector<std::size_t> order(candidates.options.size());
    std::iota(order.begin(), order.end(), 0);
    for (int sample = 0; sample < params.samples; ++sample) {
        if (sample > 0) std::shuffle(order.begin(), order.end(), rng);
        if (!keep_if_new(pairs, candidates, params, grow_tree(n, pairs, candidates.options, order),
                         &sampled)) {
            continue;
        }
        const std::vector<Tree>& trees = sampled.trees;
        if (trees.size() == 1 || trees.back().score > trees[sampled.best].score) {
            sampled.best = trees.size() - 1;
        }
    }
    return sampled;
}

// The pose of `s` implied by `option`, a candidate of a pair between s and another sensor
// that `tree` places; false when the option's pair does not join s to a placed sensor.
bool placement_through(const Tree& tree, const std::vector<PairResult>& pairs, const Option& option,
                       std::size_t s, Eigen::Isometry3d* pose) {
    const PairResult& p = pairs[option.pair];
    const auto source = static_cast<std::size_t>(p.source);
    const auto target = static_cast<std::size_t>(p.target);
    const Eigen::Isometry3d& T = option.estimate.T_target_source;
    if (source == s && target != s && tree.has[target]) {
        *pose = tree.poses[target] * T;
        return true;
    }
    if (target == s && source != s && tree.has[source]) {
        *pose = tree.poses[source] * T.inverse();
        return true;
    }
    return false;
}

// Our addition (edge_consensus.hpp, "Moves"): the valid placements one move away from the
// tree at `base_index`, appended to the sampled trees. A move re-places one non-root sensor
// through any candidate of its pairs to another placed sensor; when that lands it on a
// sensor u (two look-alikes swapped: each sits on the other's true place), u is re-placed
// through each of its candidates as well.
void add_moves_from(std::size_t base_index, const std::vector<PairResult>& pairs,
                    const Candidates& candidates, const EdgeConsensusParams& params,
                    SampledTrees* sampled) {
    const Tree base = sampled->trees[base_index];
    const std::size_t n = base.has.size();
    for (std::size_t s = 1; s < n; ++s) {
        if (!base.has[s]) continue;
        for (const Option& option : candidates.options) {
            Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
            if (!placement_through(base, pairs, option, s, &pose)) continue;
            Tree moved = base;
            moved.poses[s] = pose;
            const std::size_t u = sensor_on(moved, s, params);
            if (u == n) {
                keep_if_new(pairs, candidates, params, std::move(moved), sampled);
                continue;
            }
            if (u == 0) continue;  // the root stays where it defines the frame
            for (const Option& second : candidates.options) {
                if (!placement_through(moved, pairs, second, u, &pose)) continue;
                Tree both = moved;
                both.poses[u] = pose;
                keep_if_new(pairs, candidates, params, std::move(both), sampled);
            }
        }
    }
}

// The figures of t's candidates on the pairs where t and `other` use different ones,
// pooled: support summed, p2p error as the support-weighted RMS, free-space violation shares
// summed (each pair is one more independent look at the same placements; with one
// differing pair these are that pair's figures).
PairAlternative pooled(const Tree& t, const Tree& other, const Candidates& candidates) {
    PairAlternative sum;
    double weighted_sq_error = 0.0;
    for (std::size_t e : candidates.good) {
        if (t.pick[e] == other.pick[e] || t.pick[e] < 0) continue;
        const PairAlternative& o = candidates.options[t.pick[e]].estimate;
        sum.p2p_inliers += o.p2p_inliers;
        weighted_sq_error += static_cast<double>(o.p2p_inliers) * o.p2p_error_m * o.p2p_error_m;
        sum.free_space_violation_share += o.free_space_violation_share;
    }
    if (sum.p2p_inliers > 0)
        sum.p2p_error_m = std::sqrt(weighted_sq_error / static_cast<double>(sum.p2p_inliers));
    return sum;
}

// `a` clearly beats `b` on the pairs where they use different candidates, figures pooled.
bool tree_clearly_better(const Tree& a, const Tree& b, const Candidates& candidates,
                         const AmbiguityParams& params) {
    return clearly_better(pooled(a, b, candidates), pooled(b, a, candidates), params);
}

// Another tree that reaches as many sensors as `best` and explains at least
// AmbiguityParams::rival_pair_share of its pairs.
bool rivals(const Tree& challenger, const Tree& best, const AmbiguityParams& params) {
    return &challenger != &best && challenger.score.reached == best.score.reached &&
           challenger.score.consistent >= params.rival_pair_share * best.score.consistent;
}

// The winner after every rival clearly better than the winner took its place (bounded:
// the relation has no cycles in practice, but the loop must end regardless).
std::size_t clearly_better_rival(const SampledTrees& sampled, const Candidates& candidates,
                                 const AmbiguityParams& params) {
    const std::vector<Tree>& trees = sampled.trees;
    std::size_t best = sampled.best;
    for (std::size_t pass = 0; pass < trees.size(); ++pass) {
        bool replaced = false;
        for (std::size_t t = 0; t < trees.size() && !replaced; ++t) {
            if (rivals(trees[t], trees[best], params) &&
                tree_clearly_better(trees[t], trees[best], candidates, params)) {
                best = t;
                replaced = true;
            }
        }
        if (!replaced) break;
    }
    return best;
}

// The sensors a rival places differently from the winner, unless the winner clearly beats
// it; counts the rivals.
void mark_ambiguous(const SampledTrees& sampled, const Candidates& candidates,
                    const EdgeConsensusParams& params, EdgeConsensusResult* result) {
    const Tree& winner = sampled.trees[sampled.best];
    for (const Tree& t : sampled.trees) {
        if (!rivals(t, winner, params.ambiguity)) continue;
        ++result->rival_trees;
        if (tree_clearly_better(winner, t, candidates, params.ambiguity)) continue;
        const std::vector<bool> differ = differing_sensors(winner, t, params);
        for (std::size_t i = 0; i < differ.size(); ++i)
            result->ambiguous[i] = result->ambiguous[i] || differ[i];
    }
}

// Drops the good pairs that touch a refused sensor or have no candidate consistent with
// the winner (no winner: every one), and makes each other pair's consistent candidate its
// chosen one, the previous choice joining the alternatives.
void keep_winner_candidates(const EdgeConsensusResult& result, const Tree* winner,
                            const Candidates& candidates, std::vector<PairResult>* pairs,
                            std::vector<bool>* edge_ok) {
    for (std::size_t e : candidates.good) {
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
        const int k = winner == nullptr ? -1 : winner->pick[e];
        if (k < 0) {
            p.status = PairStatus::kRejectedByPoseGraph;
            (*edge_ok)[e] = false;
            continue;
        }
        const PairAlternative pick = candidates.options[k].estimate;
        if (pick.candidate != p.chosen.candidate) {
            std::vector<PairAlternative> others{p.chosen};
            for (const PairAlternative& a : p.alternatives) {
                if (a.candidate != pick.candidate) others.push_back(a);
            }
            p.chosen = pick;
            p.alternatives = std::move(others);
        }
    }
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
    const Candidates candidates = collect_candidates(*pairs, *edge_ok);
    if (candidates.good.empty() || n == 0) return result;

    SampledTrees sampled = sample_trees(n, *pairs, candidates, params);
    if (params.ambiguity.enabled && !sampled.trees.empty()) {
        sampled.best = clearly_better_rival(sampled, candidates, params.ambiguity);
        // The moves only ever refuse: a move that explains the pairs about as well as the
        // winner and places some sensor elsewhere makes that sensor ambiguous; none replaces
        // the winner (pooled figures judged look-alikes "clearly better" in one of eight
        // 8-sensor captures, bench/BENCHMARK.md).
        if (params.moves) add_moves_from(sampled.best, *pairs, candidates, params, &sampled);
        mark_ambiguous(sampled, candidates, params, &result);
    }
    const Tree* winner = sampled.trees.empty() ? nullptr : &sampled.trees[sampled.best];
    if (winner != nullptr && params.min_bridge_information_per_inlier > 0) {
        mark_beyond_weak_bridges(n, *pairs, candidates.good, candidates.options, *winner, params,
                                 &result.unconfirmed);
    }
    keep_winner_candidates(result, winner, candidates, pairs, edge_ok);
    return result;
}

}  // namespace lidarfuse::core
