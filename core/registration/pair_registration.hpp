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
// have a G-ICP inlier share of at least `min_overlap_share`. Every candidate must also be
// consistent with what both sensors saw: few points of either in the other's observed
// free space (`max_free_space_violation_share`, free_space_check.hpp).
//
// Deterministic: RANSAC is seeded (params.ransac.seed, plus the round number).
// Single-threaded unless register_pair's `num_threads` > 1 (G-ICP, p2p).

#include <Eigen/Geometry>
#include <algorithm>
#include <cstddef>

#include "core/features/feature_matching.hpp"
#include "core/features/sensor_features.hpp"
#include "core/initial/ground_aligned_search.hpp"
#include "core/registration/free_space_check.hpp"
#include "core/registration/gicp.hpp"
#include "core/registration/p2p_error.hpp"
#include "core/registration/ransac.hpp"

namespace lidarfuse::core {

struct PairRegistrationParams {
    // Our addition: candidates from the exhaustive yaw/translation vote in the levelled
    // ground frames come first (ground_aligned_search.hpp); the paper's RANSAC rounds run
    // only when none of them survives the checks below: few of the descriptor matches RANSAC
    // gets are right (bench/BENCHMARK.md; the reasoning is in ground_aligned_search.hpp).
    bool use_ground_aligned_search = true;
    GroundAlignedSearchParams ground_search{};
    // Coarse free-space check on a ground-aligned candidate before G-ICP (its error is
    // about one vote cell and one yaw step): loose, above the right candidates' shares, so it
    // drops only clearly wrong peaks; G-ICP and the finer checks judge the rest.
    double max_ground_coarse_free_space_violation_share = 0.15;
    FeatureMatchingParams matching{};
    RansacParams ransac{};
    // Coarse-to-fine G-ICP: one run per correspondence distance bound (m), each starting
    // at the previous result.
    std::vector<double> gicp_max_correspondence_m{1.5, 0.5};
    // Iteration limit of every run but the last: the coarse runs only bring a candidate
    // into the last run's basin, and wrong candidates otherwise use every iteration.
    int gicp_coarse_max_iterations = 10;
    GicpParams gicp{};
    // r_c of the p2p error (m); the paper: about the largest octree voxel size.
    double p2p_cutoff_m = 1.0;
    // Candidates (RANSAC rounds) of the wrong-majority guard; 1 disables it.
    int max_candidates = 6;
    double min_support_share = 0.5;
    // Every candidate's G-ICP inliers / source points must reach this (candidates that
    // overlap a small patch trivially have a low p2p error).
    double min_overlap_share = 0.15;
    // Candidates that put the source sensor within this distance of the target sensor are
    // dropped (m): two sensors cannot share a place, and on a symmetric site the best
    // look-alike is "the source sees what the target sees", with more overlap and less p2p
    // error than the right candidate. Sensors mounted closer than this on one pole cannot be
    // calibrated.
    double min_sensor_separation_m = 0.5;
    // Candidates whose transforms differ by less than this (m, at the source origin) are
    // one alternative.
    double alternative_separation_m = 1.0;
    // Our addition: a candidate counts only if the smallest eigenvalue of its G-ICP
    // Hessian per G-ICP inlier reaches this (the unitless information of covariances with
    // epsilon 1e-3). Off (0) by default: on the simulator's captures a right pair fell below
    // what wrong candidates passed easily, and the free-space check below rejects wrong ones
    // on principle (bench/BENCHMARK.md).
    double min_information_per_inlier = 0.0;
    // Our addition (visibility, free_space_check.hpp): a candidate is dropped when more
    // than this share of one sensor's points lie in the other sensor's observed free space
    // (checked both ways, the G-ICP clouds against each sensor's FreeSpaceMap, built with
    // SensorFeatureParams::free_space). Measured on `lidarfuse sim` captures and on the real
    // rigs: bench/BENCHMARK.md.
    double max_free_space_violation_share = 0.08;
    // The same check on the RANSAC transform, before G-ICP (saves refining hopeless
    // candidates); looser, because the RANSAC transform is off by up to ~the RANSAC inlier
    // threshold.
    double max_coarse_free_space_violation_share = 0.35;
    // When set, the one transform to refine and check instead of searching (the initial
    // registration's loop closure: a pair whose sensors the consensus placed, started from
    // the placement). Must outlive the call.
    const Eigen::Isometry3d* start_T_target_source = nullptr;
};

enum class PairStatus {
    kOk,
    kSensorFailed,         // one of the two sensors has no usable features
    kTooFewMatches,        // fewer than 3 descriptor matches
    kNoConsensus,          // RANSAC found no upright consistent subset
    kRefinementFailed,     // G-ICP did not converge, or flipped the up axis
    kLowOverlap,           // below min_overlap_share after refinement
    kSameSensorPosition,   // every candidate put the source onto the target's position
    kDegenerate,           // G-ICP Hessian not positive definite, or too weak
                           // (min_information_per_inlier) for every candidate
    kFreeSpaceViolated,    // every refined candidate put points into the other sensor's
                           // observed free space (max_free_space_violation_share)
    kRejectedByPoseGraph,  // disagrees with the other pairs (set by the caller)
    kAmbiguous,            // a look-alike candidate explains the pair as well and no other
                           // pair decides (set by the caller, edge_consensus.hpp)
    kUnconfirmed,          // the only link of some sensor to the root, no cycle confirms it,
                           // and its G-ICP is weakly constrained (edge_consensus.hpp)
};

const char* to_string(PairStatus status);

struct PairTimings {
    double matching_s = 0.0;
    double ransac_s = 0.0;
    double gicp_s = 0.0;
    double p2p_s = 0.0;
    double ground_search_s = 0.0;
};

// A candidate that passed every check, with its figures: the one register_pair chose
// (PairResult::chosen) or one that did not have the lowest p2p error (an alternative). On a
// symmetric site the right transform can lose to a look-alike by p2p error alone; the
// initial registration's consensus over all pairs may pick an alternative instead.
struct PairAlternative {
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    Matrix6d information = Matrix6d::Zero();  // G-ICP Hessian at T_target_source
    std::size_t ransac_inliers = 0;           // support of its seed: peak or RANSAC inliers
    // Position in the order tried: the ground-aligned peaks (strongest first), then the
    // RANSAC rounds (0 = the first RANSAC majority when the ground-aligned search is off or
    // found nothing).
    int candidate = -1;
    double p2p_error_m = 0.0;
    std::size_t p2p_inliers = 0;  // N of the p2p metric
    double overlap_share = 0.0;   // N / source points
    std::size_t gicp_inliers = 0;
    double min_hessian_eigenvalue = 0.0;              // of the full 6x6 H
    double min_translation_hessian_eigenvalue = 0.0;  // of its translation block
    double free_space_violation_share = 0.0;          // the worse of the two directions
};

// Smallest G-ICP Hessian eigenvalue per G-ICP inlier: how well a candidate constrains all
// six directions, whatever its size (PairRegistrationParams::min_information_per_inlier,
// EdgeConsensusParams::min_bridge_information_per_inlier).
inline double information_per_inlier(double min_hessian_eigenvalue, std::size_t gicp_inliers) {
    return min_hessian_eigenvalue / static_cast<double>(std::max<std::size_t>(gicp_inliers, 1));
}

// What became of every candidate transform register_pair tried (diagnostics: the benches
// print these against the truth to see which check separates right from wrong).
enum class CandidateOutcome {
    kKept,                // passed every check (the chosen one or an alternative)
    kSameSensorPosition,  // min_sensor_separation_m, before or after G-ICP
    kCoarseFreeSpace,     // max_(ground_)coarse_free_space_violation_share, before G-ICP
    kRefinementFailed,    // G-ICP failed, or flipped the up axis
    kLowOverlap,          // G-ICP inlier share below min_overlap_share
    kNoP2pOverlap,        // no source point within r_c of the target
    kWeak,                // min_information_per_inlier
    kFreeSpace,           // max_free_space_violation_share, after G-ICP
};

const char* to_string(CandidateOutcome outcome);

struct CandidateRecord {
    int candidate = -1;          // position in the order tried
    bool ground_search = false;  // a ground-aligned peak (else a RANSAC round)
    std::size_t support = 0;     // peak inliers or RANSAC inliers
    CandidateOutcome outcome = CandidateOutcome::kKept;
    Eigen::Isometry3d T_initial = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_refined = Eigen::Isometry3d::Identity();  // after G-ICP, if run
    // -1 where the check was not reached.
    double coarse_free_space_share = -1.0;
    double gicp_inlier_ratio = -1.0;
    double information_per_inlier = -1.0;
    double p2p_error_m = -1.0;
    double overlap_share = -1.0;
    double free_space_share = -1.0;
};

struct PairResult {
    int source = -1;  // sensor i
    int target = -1;  // sensor j < i
    PairStatus status = PairStatus::kSensorFailed;
    // The chosen candidate: its transform, information and figures (set when some
    // candidate passed every check, whatever the status).
    PairAlternative chosen;
    std::size_t num_matches = 0;
    int ground_candidates = 0;                    // peaks of the ground-aligned search
    int candidates = 0;                           // candidates that passed every check
    double worst_rejected_violation_share = 0.0;  // largest among dropped candidates
    // True when edge_polish.hpp replaced the chosen transform, information and figures with
    // its tighter G-ICP run (after the consensus; alternatives keep register_pair's figures).
    bool polished = false;
    // The other candidates that passed every check (kOk pairs only), lowest p2p error
    // first.
    std::vector<PairAlternative> alternatives;
    // Every candidate transform tried, in order, with the check that dropped it.
    std::vector<CandidateRecord> tried;
    PairTimings timings;
};

// `num_threads`: OpenMP threads of the G-ICP and p2p runs.
PairResult register_pair(const SensorFeatures& source, const SensorFeatures& target,
                         int source_index, int target_index,
                         const PairRegistrationParams& params = {}, int num_threads = 1);

}  // namespace lidarfuse::core
