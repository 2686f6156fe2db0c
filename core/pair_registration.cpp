#include "core/pair_registration.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <limits>

namespace lidarfuse::core {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

struct Candidate {
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    GicpResult gicp;
    P2pErrorResult p2p;
    FreeSpaceResult free_space;
    std::size_t ransac_inliers = 0;
    int round = 0;
};

}  // namespace

const char* to_string(PairStatus status) {
    switch (status) {
        case PairStatus::kOk: return "ok";
        case PairStatus::kSensorFailed: return "sensor failed";
        case PairStatus::kTooFewMatches: return "too few descriptor matches";
        case PairStatus::kNoConsensus: return "no consistent correspondences";
        case PairStatus::kRefinementFailed: return "G-ICP refinement failed";
        case PairStatus::kLowOverlap: return "overlap too small";
        case PairStatus::kDegenerate: return "degenerate (weak or singular G-ICP Hessian)";
        case PairStatus::kFreeSpaceViolated: return "points in the other sensor's free space";
        case PairStatus::kRejectedByPoseGraph: return "inconsistent with the other pairs";
    }
    return "unknown";
}

PairResult register_pair(const SensorFeatures& source, const SensorFeatures& target,
                         int source_index, int target_index, const PairRegistrationParams& params) {
    PairResult result;
    result.source = source_index;
    result.target = target_index;
    if (source.status != SensorFeatureStatus::kOk || target.status != SensorFeatureStatus::kOk) {
        return result;
    }
    const int threads = std::max(1, params.num_threads);

    // Step 5a: descriptor matching.
    auto start = Clock::now();
    Correspondences remaining = match_features(source.descriptors, target.descriptors, params.matching);
    result.num_matches = remaining.size();
    result.timings.matching_s = seconds_since(start);
    if (remaining.size() < 3) {
        result.status = PairStatus::kTooFewMatches;
        return result;
    }

    GicpParams gicp_params = params.gicp;
    gicp_params.num_threads = threads;
    GicpRegistration gicp(gicp_params);
    P2pErrorParams p2p_params;
    p2p_params.cutoff_radius_m = params.p2p_cutoff_m;
    p2p_params.num_threads = threads;

    // Steps 5-8: RANSAC + Kabsch + up-vector check, G-ICP, then again without the
    // correspondences that supported the earlier candidates.
    std::vector<Candidate> candidates;
    bool any_consensus = false;
    int weak_candidates = 0;
    int free_space_rejected = 0;
    for (int round = 0; round < std::max(1, params.max_candidates) && remaining.size() >= 3; ++round) {
        start = Clock::now();
        RansacParams ransac_params = params.ransac;
        ransac_params.seed = params.ransac.seed + static_cast<std::uint32_t>(round);
        const RansacResult ransac = ransac_registration(source.keypoint_points, target.keypoint_points,
                                                        remaining, ransac_params);
        result.timings.ransac_s += seconds_since(start);
        if (!ransac.success) break;
        any_consensus = true;

        const FreeSpaceResult coarse_free_space = free_space_violations_both(
            source.gicp.cloud().points, target.gicp.cloud().points, ransac.T_target_source, params.free_space);
        const bool hopeless = coarse_free_space.violation_share > params.max_coarse_free_space_violation_share;
        if (hopeless) {
            ++free_space_rejected;
            result.worst_rejected_violation_share =
                std::max(result.worst_rejected_violation_share, coarse_free_space.violation_share);
        }

        start = Clock::now();
        Candidate candidate;
        candidate.round = round;
        candidate.ransac_inliers = ransac.inliers.size();
        candidate.T_target_source = ransac.T_target_source;
        bool refined = !hopeless;
        for (double max_distance_m : params.gicp_max_correspondence_m) {
            if (!refined) break;
            gicp_params.max_correspondence_distance_m = max_distance_m;
            gicp.set_params(gicp_params);
            candidate.gicp = gicp.align(target.gicp, source.gicp.cloud(), candidate.T_target_source);
            if (!candidate.gicp.converged && candidate.gicp.status != GicpStatus::kMaxIterations) {
                refined = false;
                break;
            }
            candidate.T_target_source = candidate.gicp.T_target_source;
        }
        result.timings.gicp_s += seconds_since(start);
        // Step 6 again after refinement: G-ICP must not have turned the ground over.
        if (refined && keeps_up_vector(candidate.T_target_source)) {
            start = Clock::now();
            candidate.p2p = p2p_error(source.gicp.cloud().points, target.gicp.tree(),
                                      candidate.T_target_source, p2p_params);
            result.timings.p2p_s += seconds_since(start);
            const double information_per_inlier =
                candidate.gicp.H_eigenvalues(0) /
                static_cast<double>(std::max<std::size_t>(candidate.gicp.num_inliers, 1));
            if (!candidate.p2p.valid) {
                // no overlap at all within r_c: not a candidate
            } else if (information_per_inlier < params.min_information_per_inlier) {
                ++weak_candidates;
            } else {
                candidate.free_space = free_space_violations_both(
                    source.gicp.cloud().points, target.gicp.cloud().points, candidate.T_target_source,
                    params.free_space);
                if (candidate.free_space.violation_share > params.max_free_space_violation_share) {
                    ++free_space_rejected;
                    result.worst_rejected_violation_share =
                        std::max(result.worst_rejected_violation_share, candidate.free_space.violation_share);
                } else {
                    candidates.push_back(candidate);
                }
            }
        }

        // Drop this round's supporters before the next round.
        std::vector<bool> used(remaining.size(), false);
        for (std::uint32_t i : ransac.inliers) used[i] = true;
        Correspondences next;
        for (std::size_t i = 0; i < remaining.size(); ++i) {
            if (!used[i]) next.push_back(remaining[i]);
        }
        remaining.swap(next);
    }
    result.candidates = static_cast<int>(candidates.size());
    if (candidates.empty()) {
        result.status = free_space_rejected > 0 ? PairStatus::kFreeSpaceViolated
                        : weak_candidates > 0   ? PairStatus::kDegenerate
                        : any_consensus     ? PairStatus::kRefinementFailed
                                            : PairStatus::kNoConsensus;
        return result;
    }

    // Lowest p2p error among the candidates with comparable support.
    std::size_t max_support = 0;
    for (const Candidate& c : candidates) max_support = std::max(max_support, c.p2p.num_within_cutoff);
    const Candidate* best = nullptr;
    for (const Candidate& c : candidates) {
        if (static_cast<double>(c.p2p.num_within_cutoff) <
            params.min_support_share * static_cast<double>(max_support)) {
            continue;
        }
        if (best == nullptr || c.p2p.error_m < best->p2p.error_m) best = &c;
    }

    result.T_target_source = best->T_target_source;
    result.information = best->gicp.H;
    result.ransac_inliers = best->ransac_inliers;
    result.chosen_candidate = best->round;
    result.p2p_error_m = best->p2p.error_m;
    result.p2p_inliers = best->p2p.num_within_cutoff;
    result.overlap_share = best->p2p.overlap_share;
    result.gicp_inliers = best->gicp.num_inliers;
    result.min_hessian_eigenvalue = best->gicp.H_eigenvalues(0);
    result.min_translation_hessian_eigenvalue = best->gicp.H_translation_eigenvalues(0);
    result.free_space_violation_share = best->free_space.violation_share;
    if (best->gicp.inlier_ratio < params.min_overlap_share) {
        result.status = PairStatus::kLowOverlap;
        return result;
    }
    const Eigen::LLT<Matrix6d> llt(result.information);
    if (llt.info() != Eigen::Success || !result.information.allFinite()) {
        result.status = PairStatus::kDegenerate;
        return result;
    }
    result.status = PairStatus::kOk;
    return result;
}

}  // namespace lidarfuse::core
