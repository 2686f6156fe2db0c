// The records of one pair's registration: the names of its statuses and candidate outcomes.
#include "core/registration/pair_registration.hpp"

namespace lidarfuse::core {

const char* to_string(PairStatus status) {
    switch (status) {
        case PairStatus::kOk:
            return "ok";
        case PairStatus::kSensorFailed:
            return "sensor failed";
        case PairStatus::kTooFewMatches:
            return "too few descriptor matches";
        case PairStatus::kNoConsensus:
            return "no consistent correspondences";
        case PairStatus::kRefinementFailed:
            return "G-ICP refinement failed";
        case PairStatus::kLowOverlap:
            return "overlap too small";
        case PairStatus::kSameSensorPosition:
            return "source placed onto the target sensor";
        case PairStatus::kDegenerate:
            return "degenerate (weak or singular G-ICP Hessian)";
        case PairStatus::kFreeSpaceViolated:
            return "points in the other sensor's free space";
        case PairStatus::kRejectedByPoseGraph:
            return "inconsistent with the other pairs";
        case PairStatus::kAmbiguous:
            return "ambiguous: a look-alike candidate fits as well";
        case PairStatus::kUnconfirmed:
            return "unconfirmed: a weak match that no other pair confirms";
    }
    return "unknown";
}

const char* to_string(CandidateOutcome outcome) {
    switch (outcome) {
        case CandidateOutcome::kKept:
            return "kept";
        case CandidateOutcome::kSameSensorPosition:
            return "same sensor position";
        case CandidateOutcome::kCoarseFreeSpace:
            return "coarse free space";
        case CandidateOutcome::kRefinementFailed:
            return "refinement failed";
        case CandidateOutcome::kLowOverlap:
            return "low overlap";
        case CandidateOutcome::kNoP2pOverlap:
            return "no p2p overlap";
        case CandidateOutcome::kWeak:
            return "weak information";
        case CandidateOutcome::kFreeSpace:
            return "free space";
    }
    return "unknown";
}

}  // namespace lidarfuse::core
