#pragma once
// Which pairwise results the pose graph may use (our addition to PAPER.md step 9), and
// which sensors no pose may be given because the data does not decide between placements.
//
// Consensus: on a symmetric site a pair can pass every pairwise check with a look-alike
// (the intersection's arms), even with a lower p2p error than the right candidate, and the
// pose graph's worst-residual-first pruning may then keep look-alikes that agree with each
// other. So spanning trees are sampled (seeded; the max-support tree of the chosen
// candidates first) over every pair's chosen candidate and its alternatives (one per
// pair); each tree gives poses, and a tree is invalid when it puts two sensors within
// min_sensor_separation_m of each other. The valid tree under which the most pairs have a
// consistent candidate wins (ties: more sensors reached, then more p2p support); each pair
// keeps its consistent candidate, pairs without one are dropped (kRejectedByPoseGraph).
//
// Ambiguity: a cycle can veto a look-alike only where there is a cycle. With two sensors,
// or a sensor that overlaps just one other, the winning tree is decided by p2p support
// alone, and a narrow view (e.g. one 90-deg sector of a street) can match two places
// about equally well. So a rival tree that explains nearly as many pairs (rival_pair_share
// below), reaches as many sensors
// and puts some sensor elsewhere must be beaten clearly (clearly_better below) on the
// pairs where the two trees use different candidates, their figures pooled (support and
// free-space shares summed, p2p error as the support-weighted RMS); a rival that is
// clearly better replaces the winner; otherwise the sensors the two trees place
// differently are refused (their pairs get kAmbiguous) rather than guessed. Pooled, so that
// small per-pair differences (above all in free-space share) add up to a clear one.
//
// Moves: random spanning trees rarely place every sensor of a large station right at once
// (8 sensors with several look-alike candidates each), so the rival that would show a
// sensor's placement ambiguous can be missing from the samples: two sensors swapped, each
// at the other's place turned by 180 deg, explained as many pairs as the right placement,
// which no sample reached. So the placements one move away from the winner are rivals
// too: each non-root sensor re-placed through every other candidate of its pairs, and when
// that lands it on a sensor, that one re-placed through every candidate of its own. They
// can only refuse sensors, never replace the winner: on pooled figures a look-alike move
// was "clearly better" than a right winner in one of eight 8-sensor captures
// (bench/BENCHMARK.md, "Swapped look-alikes at 8 sensors").
//
// Deterministic for fixed params. Single-threaded.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/registration/pair_registration.hpp"

namespace lidarfuse::core {

// "Clearly better" between two candidates of one pair, on the three figures of how well a
// transform explains both scans: p2p support N (more is better), p2p error (less is
// better) and free-space violation share (less is better). A candidate is clearly better
// when it is worse than the other by no more than the figure's tolerance on every figure
// and better by at least that much on one. The tolerances separate a right candidate from
// its best look-alike, but not two look-alikes from each other (bench/BENCHMARK.md).
struct AmbiguityParams {
    bool enabled = true;
    // A candidate with less than this share of the other's p2p support is clearly worse
    // whatever its error (PairRegistrationParams::min_support_share: a transform that
    // overlaps a small patch trivially has a low p2p error). Look-alikes support a smaller
    // share of the source than right candidates (bench/BENCHMARK.md).
    double min_support_share = 0.5;
    double support_share = 0.10;     // relative to the larger N
    double error_share = 0.10;       // relative to the larger p2p error
    double free_space_share = 0.02;  // absolute, in violation share
    // A rival tree explains at least this share of the winner's consistent pairs (and
    // reaches as many sensors). Not all of them: where the scene repeats itself (a
    // symmetric crossing), a pair's right candidate can be missing from its alternatives
    // while its look-alike is there, so look-alikes that agree with each other explain more
    // pairs than the right placements (bench/BENCHMARK.md, "8 sensors on the intersection").
    double rival_pair_share = 0.8;
};

bool clearly_better(const PairAlternative& a, const PairAlternative& b,
                    const AmbiguityParams& params);

struct EdgeConsensusParams {
    // A pair's candidate is consistent with a tree's poses within these (m, deg).
    double max_edge_translation_m = 0.25;
    double max_edge_rotation_deg = 1.0;
    int samples = 256;
    std::uint32_t seed = 1;
    // Moves (ambiguity only): the placements one move away from the winner, a sensor
    // re-placed through another candidate of one of its pairs (and a sensor that lands on
    // it re-placed too), are rivals like the sampled trees, but never replace the winner.
    bool moves = true;
    double min_sensor_separation_m = 0.5;
    AmbiguityParams ambiguity{};
    // Unconfirmed: a consistent pair of the winning tree that is a bridge (no cycle of
    // consistent pairs runs through it: a station of two, or a sensor that overlaps only
    // one other) decides the sensors beyond it alone. They are refused when its G-ICP is
    // weakly constrained: smallest Hessian eigenvalue per G-ICP inlier below this (0: off).
    double min_bridge_information_per_inlier = 0.0;
};

struct EdgeConsensusResult {
    // Per sensor: placed differently by a rival tree that the winner does not clearly
    // beat. Every good pair touching such a sensor was dropped with kAmbiguous.
    std::vector<bool> ambiguous;
    // Per sensor: beyond a weak bridge (min_bridge_information_per_inlier). Every good pair
    // touching such a sensor was dropped with kUnconfirmed.
    std::vector<bool> unconfirmed;
    int rival_trees = 0;  // distinct valid trees nearly as good as the winner by pair count
};

// `edge_ok[e]`: pair e may be used (status kOk). Pairs dropped here get their status set
// and edge_ok false; kept pairs may have a different candidate chosen (PairResult::chosen).
EdgeConsensusResult select_consistent_edges(std::size_t num_sensors, std::vector<PairResult>* pairs,
                                            std::vector<bool>* edge_ok,
                                            const EdgeConsensusParams& params);

}  // namespace lidarfuse::core
