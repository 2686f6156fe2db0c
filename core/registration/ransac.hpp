#pragma once
// Seeded RANSAC over putative correspondences (PAPER.md step 5): 3-point minimal samples,
// a cheap pre-rejection of samples whose triangle edge lengths differ between source and
// target (a rigid motion preserves them), Kabsch for each hypothesis, the up-vector check
// (step 6: a hypothesis that maps the source's up axis (0,0,1) to a vector with negative z
// would flip the ground upside down and is rejected), inlier counting with a metric
// threshold, and an early exit once the best hypothesis is found with the requested
// confidence. The winner is refitted on all its inliers.
//
// Deterministic: the same input and seed give the same result (single-threaded).

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "core/registration/correspondence.hpp"

namespace lidarfuse::core {

struct RansacParams {
    // A correspondence is an inlier when |T * source - target| <= this (m).
    double inlier_threshold_m = 1.0;
    int max_iterations = 20000;
    // Stop once the probability of having drawn one all-inlier sample exceeds this.
    double confidence = 0.999;
    // Pre-rejection: every edge of the sample triangle must satisfy
    // min(l_s, l_t) / max(l_s, l_t) >= edge_similarity (1 = exact).
    double edge_similarity = 0.9;
    // Samples whose source triangle has an edge shorter than this are degenerate (m).
    double min_edge_length_m = 0.3;
    // Reject hypotheses that turn the source's up direction away from the target's
    // (PAPER.md step 6: the paper's up is each sensor's +z, "not mounted upside down"; where
    // the road plane is known its normal is the up, so that sensors tilted by 45 deg or
    // more, whose +z axes may point apart, are not refused: see keeps_up_vector).
    bool reject_upside_down = true;
    Eigen::Vector3d source_up = Eigen::Vector3d::UnitZ();  // unit, source frame
    Eigen::Vector3d target_up = Eigen::Vector3d::UnitZ();  // unit, target frame
    // Fewer inliers than this is a failure.
    int min_inliers = 6;
    // Refit-and-recount rounds on the winner's inliers.
    int refine_rounds = 3;
    std::uint32_t seed = 1;
};

struct RansacResult {
    bool success = false;
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    // Indices into the input correspondences that agree with T_target_source.
    std::vector<std::uint32_t> inliers;
    // Inlier count minus the normalised residual sum (higher is better): ties between
    // equal counts go to the tighter fit.
    double score = 0.0;
    // RMS residual of the inliers (m).
    double inlier_rms_m = 0.0;
    int iterations = 0;
    // Samples rejected before a fit by the edge-length test, and fits rejected by the
    // up-vector check.
    int prerejected_samples = 0;
    int upside_down_hypotheses = 0;
};

// True when R * source_up does not point against target_up: the transform does not turn
// the world upside down. With the default +z axes: R * (0,0,1) has non-negative z.
bool keeps_up_vector(const Eigen::Isometry3d& T_target_source,
                     const Eigen::Vector3d& source_up = Eigen::Vector3d::UnitZ(),
                     const Eigen::Vector3d& target_up = Eigen::Vector3d::UnitZ());

// `source_points[c.source]` and `target_points[c.target]` for every correspondence c.
RansacResult ransac_registration(const std::vector<Eigen::Vector3d>& source_points,
                                 const std::vector<Eigen::Vector3d>& target_points,
                                 const Correspondences& correspondences,
                                 const RansacParams& params = {});

}  // namespace lidarfuse::core
