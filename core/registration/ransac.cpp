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
    const std::size_t n = correspondences.size();
    for (const Correspondence& c : correspondences) {
        if (c.source >= source_points.size() || c.target >= target_points.size()) return result;
    }
    if (n < 3 || params.max_iterations <= 0 || !(params.inlier_threshold_m > 0.0)) return result;

    const double threshold_sq = params.inlier_threshold_m * params.inlier_threshold_m;
    const double min_edge_sq = params.min_edge_length_m * params.min_edge_length_m;
    const double similarity_sq = params.edge_similarity * params.edge_similarity;
    std::mt19937 rng(params.seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);

    Consensus best;
    Eigen::Isometry3d best_T = Eigen::Isometry3d::Identity();
    double needed = static_cast<double>(params.max_iterations);
    std::vector<Eigen::Vector3d> sample_source(3);
    std::vector<Eigen::Vector3d> sample_target(3);

    int iteration = 0;
    for (; iteration < params.max_iterations && iteration < needed; ++iteration) {
        std::array<std::size_t, 3> idx{pick(rng), pick(rng), pick(rng)};
        if (idx[0] == idx[1] || idx[0] == idx[2] || idx[1] == idx[2]) continue;
        bool reject = false;
        for (int k = 0; k < 3 && !reject; ++k) {
            const Correspondence& a = correspondences[idx[k]];
            const Correspondence& b = correspondences[idx[(k + 1) % 3]];
            if (a.source == b.source || a.target == b.target) {
                reject = true;
                break;
            }
            // A rigid motion keeps edge lengths: compare squared lengths to avoid sqrt.
            const double ls = (source_points[a.source] - source_points[b.source]).squaredNorm();
            const double lt = (target_points[a.target] - target_points[b.target]).squaredNorm();
            if (ls < min_edge_sq || lt < min_edge_sq ||
                std::min(ls, lt) < similarity_sq * std::max(ls, lt)) {
                reject = true;
            }
        }
        if (reject) {
            ++result.prerejected_samples;
            continue;
        }
        for (int k = 0; k < 3; ++k) {
            sample_source[k] = source_points[correspondences[idx[k]].source];
            sample_target[k] = target_points[correspondences[idx[k]].target];
        }
        const KabschResult fit = estimate_rigid_transform(sample_source, sample_target);
        if (!fit.valid) continue;
        if (params.reject_upside_down &&
            !keeps_up_vector(fit.T_target_source, params.source_up, params.target_up)) {
            ++result.upside_down_hypotheses;
            continue;
        }
        const Consensus consensus = evaluate(fit.T_target_source, source_points, target_points,
                                             correspondences, threshold_sq, nullptr);
        if (consensus.count > best.count ||
            (consensus.count == best.count && consensus.score > best.score)) {
            best = consensus;
            best_T = fit.T_target_source;
            needed = required_iterations(static_cast<double>(best.count) / static_cast<double>(n),
                                         params.confidence);
        }
    }
    result.iterations = iteration;
    if (best.count < std::max(3, params.min_inliers)) return result;

    // Refit on all inliers, recount, and keep the refit only while it does not lose support.
    std::vector<std::uint32_t> inliers;
    evaluate(best_T, source_points, target_points, correspondences, threshold_sq, &inliers);
    for (int round = 0; round < params.refine_rounds; ++round) {
        const KabschResult fit =
            estimate_rigid_transform(source_points, target_points, correspondences, inliers);
        if (!fit.valid) break;
        if (params.reject_upside_down &&
            !keeps_up_vector(fit.T_target_source, params.source_up, params.target_up))
            break;
        std::vector<std::uint32_t> refit_inliers;
        const Consensus consensus = evaluate(fit.T_target_source, source_points, target_points,
                                             correspondences, threshold_sq, &refit_inliers);
        if (consensus.count < best.count) break;
        const bool unchanged = refit_inliers == inliers;
        best = consensus;
        best_T = fit.T_target_source;
        inliers.swap(refit_inliers);
        if (unchanged) break;
    }

    result.success = true;
    result.T_target_source = best_T;
    result.inliers = std::move(inliers);
    result.score = best.score;
    result.inlier_rms_m = std::sqrt(best.squared_sum / std::max(best.count, 1));
    return result;
}

}  // namespace lidarfuse::core
