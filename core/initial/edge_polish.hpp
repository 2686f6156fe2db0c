#pragma once
// Our addition to the initial registration: a last, tighter G-ICP run on the pairs the
// consensus kept (edge_consensus.hpp), before the pose graph.
//
// register_pair refines every candidate with a correspondence bound of 0.5 m, and its
// checks (overlap share, p2p error, free space) are tuned on those results: a tighter
// bound there drops right candidates for low overlap. Once a pair is
// chosen, a tighter bound only has to sharpen it: the correspondences that a 0.5 m bound
// admits across neighboring surfaces (a pole next to a wall, the kerb next to the road)
// pull the two clouds' voxel centroids towards each other and leave a centimetre-level
// bias (bench/BENCHMARK.md).
//
// The runs use each sensor's finer polish cloud (SensorFeatureParams::polish_voxel_size_m,
// 0.25 m) when it has one. The cloud and bound were chosen on the 30 simulated captures,
// for a smaller worst error at the same median; the table and the cost are in
// bench/BENCHMARK.md ("Edge polish").
//
// A polished edge replaces the pair's transform and information (and the figures that
// describe them: G-ICP inliers and Hessian eigenvalues, and the p2p error recomputed on
// the G-ICP cloud) only when every run converged (or stopped at its iteration cap), the
// up axis stayed up, enough of the source still overlaps, and the move stays within the
// polish limits (it refines; it never re-decides the pair). Otherwise the pair keeps its
// register_pair result.

#include <cstddef>
#include <vector>

#include "core/features/sensor_features.hpp"
#include "core/registration/gicp.hpp"
#include "core/registration/pair_registration.hpp"

namespace lidarfuse::core {

struct EdgePolishParams {
    // One G-ICP run per bound (m), each starting at the previous result; empty: no polish.
    std::vector<double> max_correspondence_m{0.4};
    // Everything else of the runs (iterations, thresholds, kernel); register_initial sets
    // it to the pair registration's. Its bound is overridden, its thread count set to 1.
    GicpParams gicp{};
    // The polished transform may move this far from the chosen one (m at the source
    // origin, degrees); farther means the tight bound found something else.
    double max_shift_m = 0.1;
    double max_rotation_deg = 0.5;
    // The last run's inliers / source points must reach this.
    double min_overlap_share = 0.1;
    // r_c of the p2p error recomputed at the polished transform (register_initial sets it
    // to the pair registration's).
    double p2p_cutoff_m = 1.0;
};

struct EdgePolishSummary {
    std::size_t polished = 0;  // edges whose transform and information were replaced
    std::size_t kept = 0;      // edges that kept their register_pair result
};

// Polishes pairs[e] for every e with edge_ok[e]; `features` indexed by sensor. The edges run
// in parallel on `num_threads` OpenMP threads, each edge's G-ICP on one.
EdgePolishSummary polish_edges(const std::vector<SensorFeatures>& features,
                               const std::vector<bool>& edge_ok, const EdgePolishParams& params,
                               std::vector<PairResult>* pairs, int num_threads = 1);

}  // namespace lidarfuse::core
