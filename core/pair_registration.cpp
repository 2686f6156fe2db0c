#include "core/pair_registration.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <limits>

#include "core/se3.hpp"

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
        case PairStatus::kSameSensorPosition: return "source placed onto the target sensor";
        case PairStatus::kDegenerate: return "degenerate (weak or singular G-ICP Hessian)";
        case PairStatus::kFreeSpaceViolated: return "points in the other sensor's free space";
        case PairStatus::kRejectedByPoseGraph: return "inconsistent with the other pairs";
        case PairStatus::kAmbiguous: return "ambiguous: a look-alike candidate fits as well";
        case PairStatus::kUnconfirmed: return "unconfirmed: a weak match that no other pair confirms";
    }
    return "unknown";
}

const char* to_string(CandidateOutcome outcome) {
    switch (outcome) {
        case CandidateOutcome::kKept: return "kept";
        case CandidateOutcome::kSameSensorPosition: return "same sensor position";
        case CandidateOutcome::kCoarseFreeSpace: return "coarse free space";
        case CandidateOutcome::kRefinementFailed: return "refinement failed";
        case CandidateOutcome::kLowOverlap: return "low overlap";
        case CandidateOutcome::kNoP2pOverlap: return "no p2p overlap";
        case CandidateOutcome::kWeak: return "weak information";
        case CandidateOutcome::kFreeSpace: return "free space";
    }
    return "unknown";
}

PairAlternative PairResult::chosen() const {
    PairAlternative a;
    a.T_target_source = T_target_source;
    a.information = information;
    a.ransac_inliers = ransac_inliers;
    a.candidate = chosen_candidate;
    a.p2p_error_m = p2p_error_m;
    a.p2p_inliers = p2p_inliers;
    a.overlap_share = overlap_share;
    a.gicp_inliers = gicp_inliers;
    a.min_hessian_eigenvalue = min_hessian_eigenvalue;
    a.min_translation_hessian_eigenvalue = min_translation_hessian_eigenvalue;
    a.free_space_violation_share = free_space_violation_share;
    return a;
}

void PairResult::choose(const PairAlternative& a) {
    T_target_source = a.T_target_source;
    information = a.information;
    ransac_inliers = a.ransac_inliers;
    chosen_candidate = a.candidate;
    p2p_error_m = a.p2p_error_m;
    p2p_inliers = a.p2p_inliers;
    overlap_share = a.overlap_share;
    gicp_inliers = a.gicp_inliers;
    min_hessian_eigenvalue = a.min_hessian_eigenvalue;
    min_translation_hessian_eigenvalue = a.min_translation_hessian_eigenvalue;
    free_space_violation_share = a.free_space_violation_share;
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

    // One candidate transform through refinement and the checks: coarse free-space check,
    // coarse-to-fine G-ICP, up-vector check (step 6 again: G-ICP must not turn the ground
    // over), p2p error, free-space check. Survivors join `candidates`.
    std::vector<Candidate> candidates;
    int weak_candidates = 0;
    int free_space_rejected = 0;
    int same_place_rejected = 0;
    int low_overlap_rejected = 0;
    int order = 0;
    auto consider = [&](const Eigen::Isometry3d& T_initial, std::size_t support, double max_coarse_share,
                        bool ground_search) {
        const int index = order++;
        CandidateRecord& record = result.tried.emplace_back();
        record.candidate = index;
        record.ground_search = ground_search;
        record.support = support;
        record.T_initial = T_initial;
        record.T_refined = T_initial;
        auto drop = [&](CandidateOutcome outcome, int* counter) {
            record.outcome = outcome;
            if (counter != nullptr) ++*counter;
        };
        // Two sensors cannot stand in the same place: on a symmetric site (the simulated
        // intersection) the strongest look-alike puts the source onto the target's own
        // position, where it would see exactly what the target sees.
        if (T_initial.translation().norm() < params.min_sensor_separation_m) {
            return drop(CandidateOutcome::kSameSensorPosition, &same_place_rejected);
        }
        const FreeSpaceResult coarse_free_space =
            free_space_violations_both(source.gicp.cloud().points, source.free_space,
                                       target.gicp.cloud().points, target.free_space, T_initial);
        record.coarse_free_space_share = coarse_free_space.violation_share;
        if (coarse_free_space.violation_share > max_coarse_share) {
            result.worst_rejected_violation_share =
                std::max(result.worst_rejected_violation_share, coarse_free_space.violation_share);
            return drop(CandidateOutcome::kCoarseFreeSpace, &free_space_rejected);
        }
        auto start_gicp = Clock::now();
        Candidate candidate;
        candidate.round = index;
        candidate.ransac_inliers = support;
        candidate.T_target_source = T_initial;
        bool refined = true;
        for (std::size_t stage = 0; stage < params.gicp_max_correspondence_m.size(); ++stage) {
            const bool last = stage + 1 == params.gicp_max_correspondence_m.size();
            gicp_params.max_correspondence_distance_m = params.gicp_max_correspondence_m[stage];
            gicp_params.max_iterations = last ? params.gicp.max_iterations
                                              : std::min(params.gicp.max_iterations, params.gicp_coarse_max_iterations);
            gicp.set_params(gicp_params);
            candidate.gicp = gicp.align(target.gicp, source.gicp.cloud(), candidate.T_target_source);
            if (!candidate.gicp.converged && candidate.gicp.status != GicpStatus::kMaxIterations) {
                refined = false;
                break;
            }
            candidate.T_target_source = candidate.gicp.T_target_source;
        }
        result.timings.gicp_s += seconds_since(start_gicp);
        record.T_refined = candidate.T_target_source;
        record.gicp_inlier_ratio = candidate.gicp.inlier_ratio;
        if (!refined || !keeps_up_vector(candidate.T_target_source, up_direction(source),
                                         up_direction(target))) {
            return drop(CandidateOutcome::kRefinementFailed, nullptr);
        }
        if (candidate.T_target_source.translation().norm() < params.min_sensor_separation_m) {
            return drop(CandidateOutcome::kSameSensorPosition, &same_place_rejected);
        }
        if (candidate.gicp.inlier_ratio < params.min_overlap_share) {
            return drop(CandidateOutcome::kLowOverlap, &low_overlap_rejected);
        }
        auto start_p2p = Clock::now();
        candidate.p2p = p2p_error(source.gicp.cloud().points, target.gicp.tree(), candidate.T_target_source,
                                  p2p_params);
        result.timings.p2p_s += seconds_since(start_p2p);
        // No overlap at all within r_c: not a candidate.
        if (!candidate.p2p.valid) return drop(CandidateOutcome::kNoP2pOverlap, nullptr);
        record.p2p_error_m = candidate.p2p.error_m;
        record.overlap_share = candidate.p2p.overlap_share;
        record.information_per_inlier =
            information_per_inlier(candidate.gicp.H_eigenvalues(0), candidate.gicp.num_inliers);
        if (record.information_per_inlier < params.min_information_per_inlier) {
            return drop(CandidateOutcome::kWeak, &weak_candidates);
        }
        candidate.free_space = free_space_violations_both(
            source.gicp.cloud().points, source.free_space, target.gicp.cloud().points,
            target.free_space, candidate.T_target_source);
        record.free_space_share = candidate.free_space.violation_share;
        if (candidate.free_space.violation_share > params.max_free_space_violation_share) {
            result.worst_rejected_violation_share =
                std::max(result.worst_rejected_violation_share, candidate.free_space.violation_share);
            return drop(CandidateOutcome::kFreeSpace, &free_space_rejected);
        }
        record.outcome = CandidateOutcome::kKept;
        candidates.push_back(candidate);
    };

    // Our addition: candidates from the vote over yaw and translation in the levelled
    // ground frames (ground_aligned_search.hpp), when both sensors see the road; or only the
    // given start transform.
    bool any_consensus = false;
    if (params.start_T_target_source != nullptr) {
        any_consensus = true;
        consider(*params.start_T_target_source, 0, params.max_coarse_free_space_violation_share,
                 false);
    } else if (params.use_ground_aligned_search && source.ground.found && target.ground.found) {
        start = Clock::now();
        const GroundAlignedKeypoints s{&source.keypoint_points, &source.keypoint_normals, &source.descriptors,
                                       source.ground.T_ground_sensor};
        const GroundAlignedKeypoints t{&target.keypoint_points, &target.keypoint_normals, &target.descriptors,
                                       target.ground.T_ground_sensor};
        const std::vector<GroundAlignedCandidate> peaks = ground_aligned_search(s, t, params.ground_search);
        result.timings.ground_search_s = seconds_since(start);
        result.ground_candidates = static_cast<int>(peaks.size());
        any_consensus = !peaks.empty();
        for (const GroundAlignedCandidate& peak : peaks) {
            // A peak next to an already refined candidate would converge to it again.
            bool duplicate = false;
            for (const Candidate& c : candidates) {
                duplicate = duplicate || translation_error_m(peak.T_target_source, c.T_target_source) <
                                             params.alternative_separation_m;
            }
            if (duplicate) continue;
            consider(peak.T_target_source, peak.inliers.size(), params.max_ground_coarse_free_space_violation_share,
                     true);
        }
    }

    // Steps 5-8: RANSAC + Kabsch + up-vector check, G-ICP, then again without the
    // correspondences that supported the earlier candidates. With the ground-aligned
    // search on, only when it left no candidate (e.g. a sensor that sees no road).
    const bool run_ransac = candidates.empty() && params.start_T_target_source == nullptr;
    for (int round = 0; run_ransac && round < std::max(1, params.max_candidates) && remaining.size() >= 3; ++round) {
        start = Clock::now();
        RansacParams ransac_params = params.ransac;
        ransac_params.seed = params.ransac.seed + static_cast<std::uint32_t>(round);
        ransac_params.source_up = up_direction(source);
        ransac_params.target_up = up_direction(target);
        const RansacResult ransac = ransac_registration(source.keypoint_points, target.keypoint_points,
                                                        remaining, ransac_params);
        result.timings.ransac_s += seconds_since(start);
        if (!ransac.success) break;
        any_consensus = true;
        consider(ransac.T_target_source, ransac.inliers.size(), params.max_coarse_free_space_violation_share,
                 false);

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
        result.status = free_space_rejected > 0  ? PairStatus::kFreeSpaceViolated
                        : low_overlap_rejected > 0 ? PairStatus::kLowOverlap
                        : same_place_rejected > 0  ? PairStatus::kSameSensorPosition
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

    auto as_alternative = [](const Candidate& c) {
        PairAlternative a;
        a.T_target_source = c.T_target_source;
        a.information = c.gicp.H;
        a.ransac_inliers = c.ransac_inliers;
        a.candidate = c.round;
        a.p2p_error_m = c.p2p.error_m;
        a.p2p_inliers = c.p2p.num_within_cutoff;
        a.overlap_share = c.p2p.overlap_share;
        a.gicp_inliers = c.gicp.num_inliers;
        a.min_hessian_eigenvalue = c.gicp.H_eigenvalues(0);
        a.min_translation_hessian_eigenvalue = c.gicp.H_translation_eigenvalues(0);
        a.free_space_violation_share = c.free_space.violation_share;
        return a;
    };
    result.choose(as_alternative(*best));
    for (const Candidate& c : candidates) {
        const Eigen::LLT<Matrix6d> llt_c(c.gicp.H);
        if (&c == best || llt_c.info() != Eigen::Success || !c.gicp.H.allFinite()) continue;
        // The same transform reached from another start is not an alternative.
        if (translation_error_m(c.T_target_source, best->T_target_source) < params.alternative_separation_m) continue;
        bool duplicate = false;
        for (const PairAlternative& a : result.alternatives) {
            duplicate = duplicate ||
                        translation_error_m(c.T_target_source, a.T_target_source) < params.alternative_separation_m;
        }
        if (!duplicate) result.alternatives.push_back(as_alternative(c));
    }
    std::stable_sort(result.alternatives.begin(), result.alternatives.end(),
                     [](const PairAlternative& a, const PairAlternative& b) { return a.p2p_error_m < b.p2p_error_m; });
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
