#pragma once
// registration_diagnose_bench's stage-by-stage view of the initial registration: what each
// stage of every sensor and pair hands on, judged against the truth (stderr).

#include <string>
#include <vector>

#include "bench/registration_diagnose_inputs.hpp"
#include "core/initial/ground_aligned_search.hpp"
#include "core/initial/initial_registration.hpp"

namespace lidarfuse::bench {

struct StageOptions {
    core::GroundAlignedSearchParams ground_search;  // as the bench's keys set it
    bool refine_peaks = false;                      // refine and check every peak
    bool match_only = false;                        // no RANSAC rounds
};

// Steps 2-4 of every sensor, printed (points at each stage, keypoints, the ground plane
// against the truth).
std::vector<core::SensorFeatures> diagnose_features(const std::string& dir,
                                                    const DiagnoseFrame& frame,
                                                    const core::InitialRegistrationParams& params,
                                                    int threads);

// Every stage of pair source -> target: keypoint repeatability, descriptor matches and
// ranks, the checks at the truth, the ground-aligned search's peaks, the RANSAC rounds.
void diagnose_pair(const core::SensorFeatures& source, const core::SensorFeatures& target,
                   std::size_t i, std::size_t j, const Eigen::Isometry3d& T_truth,
                   const core::PairRegistrationParams& p, const StageOptions& options);

}  // namespace lidarfuse::bench
