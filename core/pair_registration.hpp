#pragma once
// Pairwise half of the initial registration (PAPER.md steps 5-8) for a source sensor i and
// a target sensor j (i > j), on their SensorFeatures:
//   match FPFH -> RANSAC (+ up-vector check) -> Kabsch -> G-ICP refinement -> the
//   wrong-majority guard: up to `max_candidates` rounds, each removing the correspondences
//   that supported the earlier candidates before RANSAC runs again; every candidate is
//   refined and scored by the p2p error (Lehtola 2017, p = 2, cut-off r_c), and the one
//   with the lowest error wins.
// Our additions to the paper's rule, both documented in the params: a candidate whose p2p
// support N is below `min_support_share` of the best candidate's cannot win on error alone
// (a transform overlapping a small patch trivially has a low error), and the winner must
// have a G-ICP inlier share of at least `min_overlap_share`.
//
// Deterministic: RANSAC is seeded (params.ransac.seed, plus the round number).
// Single-threaded unless `num_threads` > 1 (G-ICP, p2p).

#include <Eigen/Geometry>
#include <cstddef>

#include "core/feature_matching.hpp"
#include "core/gicp.hpp"
#include "core/p2p_error.hpp"
#include "core/ransac.hpp"
#include "core/sensor_features.hpp"

namespace lidarfuse::core {

struct PairRegistrationParams {
    FeatureMatchingParams matching{};
    RansacParams ransac{};
    // Coarse-to-fine G-ICP: one run per correspondence distance bound (m), each starting
    // at the previous result.
    std::vector<double> gicp_max_correspondence_m{1.5, 0.5};
    GicpParams gicp{};
    // r_c of the p2p error (m); the paper: about the largest octree voxel size.
    double p2p_cutoff_m = 1.0;
    // Candidates (RANSAC rounds) of the wrong-majority guard; 1 disables it.
    int max_candidates = 2;
    double min_support_share = 0.5;
    // The winner's G-ICP inliers / source points must reach this.
    double min_overlap_share = 0.15;
    // Our addition: a candidate counts only if the smallest eigenvalue of its G-ICP
    // Hessian per G-ICP inlier reaches this (the unitless information of covariances with
    // epsilon 1e-3). A correct alignment of a structured scene constrains all six degrees
    // of freedom (measured 30-80 on the synthetic streets); a wrong one mostly matches the
    // ground and stays below ~2.
    double min_information_per_inlier = 10.0;
    int num_threads = 1;
};

enum class PairStatus {
    kOk,
    kSensorFailed,         // one of the two sensors has no usable features
    kTooFewMatches,        // fewer than 3 descriptor matches
    kNoConsensus,          // RANSAC found no upright consistent subset
    kRefinementFailed,     // G-ICP did not converge, or flipped the up axis
    kLowOverlap,           // below min_overlap_share after refinement
    kDegenerate,           // G-ICP Hessian not positive definite, or too weak
                           // (min_information_per_inlier) for every candidate
    kRejectedByPoseGraph,  // disagrees with the other pairs (set by the caller)
};

const char* to_string(PairStatus status);

struct PairTimings {
    double matching_s = 0.0;
    double ransac_s = 0.0;
    double gicp_s = 0.0;
    double p2p_s = 0.0;
};

struct PairResult {
    int source = -1;  // sensor i
    int target = -1;  // sensor j < i
    PairStatus status = PairStatus::kSensorFailed;
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    Matrix6d information = Matrix6d::Zero();  // G-ICP Hessian at the result
    std::size_t num_matches = 0;
    std::size_t ransac_inliers = 0;
    int candidates = 0;        // RANSAC rounds that produced a refined candidate
    int chosen_candidate = -1; // 0 = the first RANSAC majority
    // Quality figures of the chosen candidate.
    double p2p_error_m = 0.0;
    std::size_t p2p_inliers = 0;  // N of the p2p metric
    double overlap_share = 0.0;   // N / source points
    std::size_t gicp_inliers = 0;
    double min_hessian_eigenvalue = 0.0;              // of the full 6x6 H
    double min_translation_hessian_eigenvalue = 0.0;  // of its translation block
    PairTimings timings;
};

PairResult register_pair(const SensorFeatures& source, const SensorFeatures& target,
                         int source_index, int target_index,
                         const PairRegistrationParams& params = {});

}  // namespace lidarfuse::core
