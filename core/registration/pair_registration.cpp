#include "core/registration/pair_registration.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "core/common/se3.hpp"
#include "core/common/stopwatch.hpp"
#include "core/registration/information.hpp"

namespace lidarfuse::core {

namespace {

// What every stage of one pair reads; all of it outlives the register_pair call.
struct PairInputs {
    const SensorFeatures& source;
    const SensorFeatures& target;
    const PairRegistrationParams& params;
    int threads = 1;  // register_pair's num_threads, at least 1
};

// A candidate transform to refine and check, and the coarse free-space bound of its origin
// (ground-aligned peaks are looser in translation and yaw than RANSAC's transforms).
struct CandidateSeed {
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    std::size_t support = 0;  // peak inliers or RANSAC inliers
    double max_coarse_free_space_share = 0.0;
    bool ground_search = false;
};

// A candidate that passed every check, with the figures the choice and the result need.
struct Candidate {
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    GicpResult gicp;
    P2pErrorResult p2p;
    FreeSpaceResult free_space;
    std::size_t ransac_inliers = 0;
    int round = 0;
};

// The candidates that passed every check, and why the others were dropped (the pair's
// status when none passes).
struct CandidateSet {
    std::vector<Candidate> kept;
    int weak = 0;
    int free_space = 0;
    int same_place = 0;
    int low_overlap = 0;
    bool any_consensus = false;  // some search produced a transform at all
};

// The G-ICP and p2p set-up every candidate of the pair is refined and scored with. One
// GicpRegistration serves every run (its buffers are reused); `gicp_params` is re-targeted
// per coarse-to-fine run.
struct PairRefiner {
    explicit PairRefiner(const PairInputs& pair)
        : gicp_params(pair.params.gicp), gicp(gicp_params, pair.threads) {
        p2p_params.cutoff_radius_m = pair.params.p2p_cutoff_m;
    }
    GicpParams gicp_params;
    GicpRegistration gicp;
    P2pErrorParams p2p_params;
};

// True when T_target_source lies within `separation_m` (at the source origin) of one of
// `items`' transforms: the same transform reached from another start.
template <typename Items>
bool near_any(const Eigen::Isometry3d& T_target_source, const Items& items, double separation_m) {
    for (const auto& item : items) {
        if (translation_error_m(T_target_source, item.T_target_source) < separation_m) return true;
    }
    return false;
}

// Step 5a: descriptor matching.
Correspondences match_descriptors(const PairInputs& pair, PairResult& result) {
    const Stopwatch stage;
    Correspondences matches =
        match_features(pair.source.descriptors, pair.target.descriptors, pair.params.matching);
    result.num_matches = matches.size();
    result.timings.matching_s = stage.seconds();
    return matches;
}

// The checks before G-ICP; kKept when the candidate is worth refining.
CandidateOutcome check_before_refinement(const PairInputs& pair, const CandidateSeed& seed,
                                         CandidateRecord& record) {
    // Two sensors cannot stand in the same place: on a symmetric site (the simulated
    // intersection) the strongest look-alike puts the source onto the target's own
    // position, where it would see exactly what the target sees.
    if (seed.T_target_source.translation().norm() < pair.params.min_sensor_separation_m) {
        return CandidateOutcome::kSameSensorPosition;
    }
    const FreeSpaceResult coarse_free_space = free_space_violations_both(
        pair.source.gicp.points(), pair.source.free_space, pair.target.gicp.points(),
        pair.target.free_space, seed.T_target_source);
    record.coarse_free_space_share = coarse_free_space.violation_share;
    if (coarse_free_space.violation_share > seed.max_coarse_free_space_share) {
        return CandidateOutcome::kCoarseFreeSpace;
    }
    return CandidateOutcome::kKept;
}

// Step 7, coarse to fine: one G-ICP run per correspondence bound, each from the previous
// result. False when a run neither converged nor stopped at its iteration limit.
bool refine_coarse_to_fine(const PairInputs& pair, PairRefiner& refiner, Candidate& candidate) {
    const PairRegistrationParams& params = pair.params;
    const std::size_t runs = params.gicp_max_correspondence_m.size();
    for (std::size_t run = 0; run < runs; ++run) {
        const bool last = run + 1 == runs;
        refiner.gicp_params.max_correspondence_distance_m = params.gicp_max_correspondence_m[run];
        refiner.gicp_params.max_iterations =
            last ? params.gicp.max_iterations
                 : std::min(params.gicp.max_iterations, params.gicp_coarse_max_iterations);
        refiner.gicp.set_params(refiner.gicp_params);
        candidate.gicp =
            refiner.gicp.align(pair.target.gicp, pair.source.gicp, candidate.T_target_source);
        if (!candidate.gicp.converged && candidate.gicp.status != GicpStatus::kMaxIterations) {
            return false;
        }
        candidate.T_target_source = candidate.gicp.T_target_source;
    }
    return true;
}

// The checks after G-ICP: up-vector (step 6 again: G-ICP must not turn the ground over),
// sensor separation, overlap, p2p error (step 8), information, free space. kKept when the
// candidate passes them all.
CandidateOutcome check_after_refinement(const PairInputs& pair, PairRefiner& refiner,
                                        Candidate& candidate, CandidateRecord& record,
                                        PairTimings& timings) {
    const PairRegistrationParams& params = pair.params;
    if (!keeps_up_vector(candidate.T_target_source, up_direction(pair.source),
                         up_direction(pair.target))) {
        return CandidateOutcome::kRefinementFailed;
    }
    if (candidate.T_target_source.translation().norm() < params.min_sensor_separation_m) {
        return CandidateOutcome::kSameSensorPosition;
    }
    if (candidate.gicp.inlier_ratio < params.min_overlap_share) {
        return CandidateOutcome::kLowOverlap;
    }
    const Stopwatch stage;
    candidate.p2p = p2p_error(pair.source.gicp.points(), pair.target.gicp.tree(),
                              candidate.T_target_source, refiner.p2p_params, pair.threads);
    timings.p2p_s += stage.seconds();
    // No overlap at all within r_c: not a candidate.
    if (!candidate.p2p.valid) return CandidateOutcome::kNoP2pOverlap;
    record.p2p_error_m = candidate.p2p.error_m;
    record.overlap_share = candidate.p2p.overlap_share;
    record.information_per_inlier =
        information_per_inlier(candidate.gicp.H_eigenvalues(0), candidate.gicp.num_inliers);
    if (record.information_per_inlier < params.min_information_per_inlier) {
        return CandidateOutcome::kWeak;
    }
    candidate.free_space = free_space_violations_both(
        pair.source.gicp.points(), pair.source.free_space, pair.target.gicp.points(),
        pair.target.free_space, candidate.T_target_source);
    record.free_space_share = candidate.free_space.violation_share;
    if (candidate.free_space.violation_share > params.max_free_space_violation_share) {
        return CandidateOutcome::kFreeSpace;
    }
    return CandidateOutcome::kKept;
}

// Counts a dropped candidate under the check that dropped it, and keeps the largest
// free-space share among the dropped ones.
void count_drop(const CandidateRecord& record, CandidateSet& set, PairResult& result) {
    switch (record.outcome) {
        case CandidateOutcome::kSameSensorPosition:
            ++set.same_place;
            break;
        case CandidateOutcome::kCoarseFreeSpace:
            ++set.free_space;
            result.worst_rejected_violation_share =
                std::max(result.worst_rejected_violation_share, record.coarse_free_space_share);
            break;
        case CandidateOutcome::kFreeSpace:
            ++set.free_space;
            result.worst_rejected_violation_share =
                std::max(result.worst_rejected_violation_share, record.free_space_share);
            break;
        case CandidateOutcome::kLowOverlap:
            ++set.low_overlap;
            break;
        case CandidateOutcome::kWeak:
            ++set.weak;
            break;
        case CandidateOutcome::kKept:
        case CandidateOutcome::kRefinementFailed:
        case CandidateOutcome::kNoP2pOverlap:
            break;
    }
}

// One candidate transform through the checks and the refinement. Every candidate is
// recorded in result.tried, in the order tried; survivors join set.kept.
void consider_candidate(const PairInputs& pair, const CandidateSeed& seed, PairRefiner& refiner,
                        CandidateSet& set, PairResult& result) {
    CandidateRecord& record = result.tried.emplace_back();
    record.candidate = static_cast<int>(result.tried.size()) - 1;
    record.ground_search = seed.ground_search;
    record.support = seed.support;
    record.T_initial = seed.T_target_source;
    record.T_refined = seed.T_target_source;
    record.outcome = check_before_refinement(pair, seed, record);
    Candidate candidate;
    candidate.round = record.candidate;
    candidate.ransac_inliers = seed.support;
    candidate.T_target_source = seed.T_target_source;
    if (record.outcome == CandidateOutcome::kKept) {
        const Stopwatch stage;
        const bool refined = refine_coarse_to_fine(pair, refiner, candidate);
        result.timings.gicp_s += stage.seconds();
        record.T_refined = candidate.T_target_source;
        record.gicp_inlier_ratio = candidate.gicp.inlier_ratio;
        record.outcome =
            refined ? check_after_refinement(pair, refiner, candidate, record, result.timings)
                    : CandidateOutcome::kRefinementFailed;
    }
    count_drop(record, set, result);
    if (record.outcome == CandidateOutcome::kKept) set.kept.push_back(candidate);
}

// Our addition: candidates from the vote over yaw and translation in the levelled ground
// frames (ground_aligned_search.hpp), strongest peak first.
void consider_ground_peaks(const PairInputs& pair, PairRefiner& refiner, CandidateSet& set,
                           PairResult& result) {
    const SensorFeatures& source = pair.source;
    const SensorFeatures& target = pair.target;
    const Stopwatch stage;
    const GroundAlignedKeypoints s{&source.keypoint_points, &source.keypoint_normals,
                                   &source.descriptors, source.ground.T_ground_sensor};
    const GroundAlignedKeypoints t{&target.keypoint_points, &target.keypoint_normals,
                                   &target.descriptors, target.ground.T_ground_sensor};
    const std::vector<GroundAlignedCandidate> peaks =
        ground_aligned_search(s, t, pair.params.ground_search);
    result.timings.ground_search_s = stage.seconds();
    result.ground_candidates = static_cast<int>(peaks.size());
    set.any_consensus = !peaks.empty();
    for (const GroundAlignedCandidate& peak : peaks) {
        // A peak next to an already refined candidate would converge to it again.
        if (near_any(peak.T_target_source, set.kept, pair.params.alternative_separation_m)) {
            continue;
        }
        const CandidateSeed seed{peak.T_target_source, peak.inliers.size(),
                                 pair.params.max_ground_coarse_free_space_violation_share, true};
        consider_candidate(pair, seed, refiner, set, result);
    }
}

// `matches` without the RANSAC inliers (indices into `matches`).
Correspondences without_supporters(const Correspondences& matches,
                                   const std::vector<std::uint32_t>& inliers) {
    std::vector<bool> used(matches.size(), false);
    for (std::uint32_t i : inliers) used[i] = true;
    Correspondences rest;
    for (std::size_t i = 0; i < matches.size(); ++i) {
        if (!used[i]) rest.push_back(matches[i]);
    }
    return rest;
}

// Steps 5-8, the wrong-majority guard: RANSAC + Kabsch + up-vector check, G-ICP, then
// again without the correspondences that supported the earlier candidates. RANSAC is
// seeded with params.ransac.seed plus the round.
void consider_ransac_rounds(const PairInputs& pair, Correspondences remaining, PairRefiner& refiner,
                            CandidateSet& set, PairResult& result) {
    const PairRegistrationParams& params = pair.params;
    for (int round = 0; round < std::max(1, params.max_candidates) && remaining.size() >= 3;
         ++round) {
        const Stopwatch stage;
        RansacParams ransac_params = params.ransac;
        ransac_params.seed = params.ransac.seed + static_cast<std::uint32_t>(round);
        ransac_params.source_up = up_direction(pair.source);
        ransac_params.target_up = up_direction(pair.target);
        const RansacResult ransac = ransac_registration(
            pair.source.keypoint_points, pair.target.keypoint_points, remaining, ransac_params);
        result.timings.ransac_s += stage.seconds();
        if (!ransac.success) break;
        set.any_consensus = true;
        const CandidateSeed seed{ransac.T_target_source, ransac.inliers.size(),
                                 params.max_coarse_free_space_violation_share, false};
        consider_candidate(pair, seed, refiner, set, result);
        remaining = without_supporters(remaining, ransac.inliers);
    }
}

// The pair's status when no candidate passed: the check that dropped some candidate, in
// this order of precedence.
PairStatus status_without_candidates(const CandidateSet& set) {
    if (set.free_space > 0) return PairStatus::kFreeSpaceViolated;
    if (set.low_overlap > 0) return PairStatus::kLowOverlap;
    if (set.same_place > 0) return PairStatus::kSameSensorPosition;
    if (set.weak > 0) return PairStatus::kDegenerate;
    return set.any_consensus ? PairStatus::kRefinementFailed : PairStatus::kNoConsensus;
}

// Step 8's choice: the lowest p2p error among the candidates whose p2p support N reaches
// min_support_share of the largest. Null only when min_support_share > 1.
const Candidate* lowest_p2p_error(const std::vector<Candidate>& candidates,
                                  double min_support_share) {
    std::size_t max_support = 0;
    for (const Candidate& c : candidates) {
        max_support = std::max(max_support, c.p2p.num_within_cutoff);
    }
    const Candidate* best = nullptr;
    for (const Candidate& c : candidates) {
        if (static_cast<double>(c.p2p.num_within_cutoff) <
            min_support_share * static_cast<double>(max_support)) {
            continue;
        }
        if (best == nullptr || c.p2p.error_m < best->p2p.error_m) best = &c;
    }
    return best;
}

PairAlternative as_alternative(const Candidate& c) {
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
}

// The candidates other than `best` with a usable (positive definite, finite) Hessian, one
// per distinct transform, lowest p2p error first.
std::vector<PairAlternative> alternatives_to(const Candidate& best,
                                             const std::vector<Candidate>& candidates,
                                             double separation_m) {
    std::vector<PairAlternative> alternatives;
    for (const Candidate& c : candidates) {
        if (&c == &best || !usable_information(c.gicp.H)) continue;
        // The same transform reached from another start is not an alternative.
        if (translation_error_m(c.T_target_source, best.T_target_source) < separation_m) continue;
        if (!near_any(c.T_target_source, alternatives, separation_m)) {
            alternatives.push_back(as_alternative(c));
        }
    }
    std::stable_sort(alternatives.begin(), alternatives.end(),
                     [](const PairAlternative& a, const PairAlternative& b) {
                         return a.p2p_error_m < b.p2p_error_m;
                     });
    return alternatives;
}

// The chosen candidate must overlap enough, and its G-ICP Hessian (the pose-graph edge's
// information) must be positive definite and finite.
PairStatus chosen_status(const Candidate& best, const PairRegistrationParams& params) {
    if (best.gicp.inlier_ratio < params.min_overlap_share) return PairStatus::kLowOverlap;
    if (!usable_information(best.gicp.H)) return PairStatus::kDegenerate;
    return PairStatus::kOk;
}

}  // namespace

PairResult register_pair(const SensorFeatures& source, const SensorFeatures& target,
                         int source_index, int target_index, const PairRegistrationParams& params,
                         int num_threads) {
    PairResult result;
    result.source = source_index;
    result.target = target_index;
    if (source.status != SensorFeatureStatus::kOk || target.status != SensorFeatureStatus::kOk) {
        return result;
    }
    const PairInputs pair{source, target, params, std::max(1, num_threads)};

    Correspondences matches = match_descriptors(pair, result);
    if (matches.size() < 3) {
        result.status = PairStatus::kTooFewMatches;
        return result;
    }

    // Candidates: the given start transform alone; else the ground-aligned peaks when both
    // sensors see the road, then the RANSAC rounds when those left no candidate (e.g. a
    // sensor that sees no road).
    PairRefiner refiner(pair);
    CandidateSet set;
    if (params.start_T_target_source != nullptr) {
        set.any_consensus = true;
        const CandidateSeed seed{*params.start_T_target_source, 0,
                                 params.max_coarse_free_space_violation_share, false};
        consider_candidate(pair, seed, refiner, set, result);
    } else if (params.use_ground_aligned_search && source.ground.found && target.ground.found) {
        consider_ground_peaks(pair, refiner, set, result);
    }
    if (set.kept.empty() && params.start_T_target_source == nullptr) {
        consider_ransac_rounds(pair, std::move(matches), refiner, set, result);
    }
    result.candidates = static_cast<int>(set.kept.size());
    if (set.kept.empty()) {
        result.status = status_without_candidates(set);
        return result;
    }

    const Candidate& best = *lowest_p2p_error(set.kept, params.min_support_share);
    result.chosen = as_alternative(best);
    result.alternatives = alternatives_to(best, set.kept, params.alternative_separation_m);
    result.status = chosen_status(best, params);
    return result;
}

}  // namespace lidarfuse::core
