#include "core/registration/ransac.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "core/registration/kabsch.hpp"

namespace lidarfuse::core {

namespace {

// Inliers of T among all correspondences and their truncated-quadratic score.
struct Consensus {
    int count = 0;
    double score = 0.0;
    double squared_sum = 0.0;
};

Consensus evaluate(const Eigen::Isometry3d& T, const std::vector<Eigen::Vector3d>& source_points,
                   const std::vector<Eigen::Vector3d>& target_points,
                   const Correspondences& correspondences, double threshold_sq,
                   std::vector<std::uint32_t>* inliers) {
    Consensus consensus;
    if (inliers != nullptr) inliers->clear();
    const Eigen::Matrix3d R = T.linear();
    const Eigen::Vector3d t = T.translation();
    for (std::size_t i = 0; i < correspondences.size(); ++i) {
        const Correspondence& c = correspondences[i];
        const double d2 = (R * source_points[c.source] + t - target_points[c.target]).squaredNorm();
        if (d2 <= threshold_sq) {
            ++consensus.count;
            consensus.score += 1.0 - d2 / threshold_sq;
            consensus.squared_sum += d2;
            if (inliers != nullptr) inliers->push_back(static_cast<std::uint32_t>(i));
        }
    }
    return consensus;
}

// Samples needed to draw one all-inlier triple with probability `confidence`.
double required_iterations(double inlier_ratio, double confidence) {
    const double p_good = inlier_ratio * inlier_ratio * inlier_ratio;
    if (p_good >= 1.0) return 1.0;
    if (p_good <= 0.0) return std::numeric_limits<double>::infinity();
    return std::log(1.0 - confidence) / std::log(1.0 - p_good);
}

// The correspondence problem of one call, read-only.
struct Problem {
    const std::vector<Eigen::Vector3d>& source_points;
    const std::vector<Eigen::Vector3d>& target_points;
    const Correspondences& correspondences;
    const RansacParams& params;
    double threshold_sq;  // inlier threshold (m^2)
};

bool indices_valid(const Problem& problem) {
    for (const Correspondence& c : problem.correspondences) {
        if (c.source >= problem.source_points.size() || c.target >= problem.target_points.size()) {
            return false;
        }
    }
    return true;
}

// True when the sample's triangles cannot be related by a rigid motion: a repeated point, an
// edge shorter than min_edge_length_m, or edge lengths that differ by more than
// edge_similarity. A rigid motion keeps edge lengths; squared lengths are compared to avoid
// the sqrt.
bool prereject(const Problem& problem, const std::array<std::size_t, 3>& idx) {
    const double min_edge_sq = problem.params.min_edge_length_m * problem.params.min_edge_length_m;
    const double similarity_sq = problem.params.edge_similarity * problem.params.edge_similarity;
    for (int k = 0; k < 3; ++k) {
        const Correspondence& a = problem.correspondences[idx[k]];
        const Correspondence& b = problem.correspondences[idx[(k + 1) % 3]];
        if (a.source == b.source || a.target == b.target) return true;
        const double ls =
            (problem.source_points[a.source] - problem.source_points[b.source]).squaredNorm();
        const double lt =
            (problem.target_points[a.target] - problem.target_points[b.target]).squaredNorm();
        if (ls < min_edge_sq || lt < min_edge_sq ||
            std::min(ls, lt) < similarity_sq * std::max(ls, lt)) {
            return true;
        }
    }
    return false;
}

// The Kabsch fit of a 3-point sample; the points are gathered into the caller's buffers
// (3 each), which the sampling loop reuses.
KabschResult fit_sample(const Problem& problem, const std::array<std::size_t, 3>& idx,
                        std::vector<Eigen::Vector3d>* sample_source,
                        std::vector<Eigen::Vector3d>* sample_target) {
    for (int k = 0; k < 3; ++k) {
        (*sample_source)[k] = problem.source_points[problem.correspondences[idx[k]].source];
        (*sample_target)[k] = problem.target_points[problem.correspondences[idx[k]].target];
    }
    return estimate_rigid_transform(*sample_source, *sample_target);
}

// The best hypothesis of the sampling loop.
struct Hypothesis {
    Consensus consensus;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
};

// Seeded minimal samples until max_iterations or the confidence is reached; counts the
// iterations and the rejections in *result.
Hypothesis sample_hypotheses(const Problem& problem, RansacResult* result) {
    const RansacParams& params = problem.params;
    const std::size_t n = problem.correspondences.size();
    std::mt19937 rng(params.seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    Hypothesis best;
    double needed = static_cast<double>(params.max_iterations);
    std::vector<Eigen::Vector3d> sample_source(3);
    std::vector<Eigen::Vector3d> sample_target(3);
    int iteration = 0;
    for (; iteration < params.max_iterations && iteration < needed; ++iteration) {
        std::array<std::size_t, 3> idx{pick(rng), pick(rng), pick(rng)};
        if (idx[0] == idx[1] || idx[0] == idx[2] || idx[1] == idx[2]) continue;
        if (prereject(problem, idx)) {
            ++result->prerejected_samples;
            continue;
        }
        const KabschResult fit = fit_sample(problem, idx, &sample_source, &sample_target);
        if (!fit.valid) continue;
        if (params.reject_upside_down &&
            !keeps_up_vector(fit.T_target_source, params.source_up, params.target_up)) {
            ++result->upside_down_hypotheses;
            continue;
        }
        const Consensus consensus =
            evaluate(fit.T_target_source, problem.source_points, problem.target_points,
                     problem.correspondences, problem.threshold_sq, nullptr);
        if (consensus.count > best.consensus.count ||
            (consensus.count == best.consensus.count && consensus.score > best.consensus.score)) {
            best.consensus = consensus;
            best.T = fit.T_target_source;
            needed = required_iterations(
                static_cast<double>(best.consensus.count) / static_cast<double>(n),
                params.confidence);
        }
    }
    result->iterations = iteration;
    return best;
}

// Refits on all inliers and recounts, keeping the refit only while it does not lose
// support; returns the final inliers.
std::vector<std::uint32_t> refine(const Problem& problem, Hypothesis* best) {
    const RansacParams& params = problem.params;
    std::vector<std::uint32_t> inliers;
    evaluate(best->T, problem.source_points, problem.target_points, problem.correspondences,
             problem.threshold_sq, &inliers);
    for (int round = 0; round < params.refine_rounds; ++round) {
        const KabschResult fit = estimate_rigid_transform(
            problem.source_points, problem.target_points, problem.correspondences, inliers);
        if (!fit.valid) break;
        if (params.reject_upside_down &&
            !keeps_up_vector(fit.T_target_source, params.source_up, params.target_up))
            break;
        std::vector<std::uint32_t> refit_inliers;
        const Consensus consensus =
            evaluate(fit.T_target_source, problem.source_points, problem.target_points,
                     problem.correspondences, problem.threshold_sq, &refit_inliers);
        if (consensus.count < best->consensus.count) break;
        const bool unchanged = refit_inliers == inliers;
        best->consensus = consensus;
        best->T = fit.T_target_source;
        inliers.swap(refit_inliers);
        if (unchanged) break;
    }
    return inliers;
}

}  // namespace

bool keeps_up_vector(const Eigen::Isometry3d& T_target_source, const Eigen::Vector3d& source_up,
                     const Eigen::Vector3d& target_up) {
    return (T_target_source.linear() * source_up).dot(target_up) >= 0.0;
}

RansacResult ransac_registration(const std::vector<Eigen::Vector3d>& source_points,
                                 const std::vector<Eigen::Vector3d>& target_points,
                                 const Correspondences& correspondences,
                                 const RansacParams& params) {
    RansacResult result;
    const Problem problem{source_points, target_points, correspondences, params,
                          params.inlier_threshold_m * params.inlier_threshold_m};
    if (!indices_valid(problem)) return result;
    if (correspondences.size() < 3 || params.max_iterations <= 0 ||
        !(params.inlier_threshold_m > 0.0)) {
        return result;
    }

    Hypothesis best = sample_hypotheses(problem, &result);
    if (best.consensus.count < std::max(3, params.min_inliers)) return result;
    std::vector<std::uint32_t> inliers = refine(problem, &best);

    result.success = true;
    result.T_target_source = best.T;
    result.inliers = std::move(inliers);
    result.score = best.consensus.score;
    result.inlier_rms_m = std::sqrt(best.consensus.squared_sum / std::max(best.consensus.count, 1));
    return result;
}

}  // namespace lidarfuse::core
