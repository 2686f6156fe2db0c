#include "core/registration/kabsch.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace lidarfuse::core {

namespace {

// Accumulates the weighted means and cross-covariance of the pairs given by `pair_at(i)`.
template <class PairAt>
KabschResult solve(std::size_t n, PairAt pair_at) {
    KabschResult result;
    if (n < 3) return result;
    double weight_sum = 0.0;
    Eigen::Vector3d mean_source = Eigen::Vector3d::Zero();
    Eigen::Vector3d mean_target = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        const auto [s, t, w] = pair_at(i);
        weight_sum += w;
        mean_source += w * s;
        mean_target += w * t;
    }
    if (!(weight_sum > 0.0)) return result;
    mean_source /= weight_sum;
    mean_target /= weight_sum;

    // Cross-covariance H = sum w (s - mean_s)(t - mean_t)^T; R = V diag(1, 1, d) U^T.
    Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
    double source_spread = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const auto [s, t, w] = pair_at(i);
        const Eigen::Vector3d ds = s - mean_source;
        cross += w * ds * (t - mean_target).transpose();
        source_spread += w * ds.squaredNorm();
    }
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
    // Collinear (or coincident) source points: the second singular value vanishes.
    const Eigen::Vector3d sigma = svd.singularValues();
    if (!(source_spread > 0.0) || sigma(1) <= 1e-9 * std::max(sigma(0), 1e-300)) return result;

    Eigen::Matrix3d correction = Eigen::Matrix3d::Identity();
    if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) correction(2, 2) = -1.0;
    const Eigen::Matrix3d rotation = svd.matrixV() * correction * svd.matrixU().transpose();

    result.T_target_source.setIdentity();
    result.T_target_source.linear() = rotation;
    result.T_target_source.translation() = mean_target - rotation * mean_source;
    double squared_sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const auto [s, t, w] = pair_at(i);
        squared_sum += w * (result.T_target_source * s - t).squaredNorm();
    }
    result.rms_error_m = std::sqrt(squared_sum / weight_sum);
    result.valid = std::isfinite(result.rms_error_m);
    return result;
}

struct Pair {
    const Eigen::Vector3d& source;
    const Eigen::Vector3d& target;
    double weight;
};

}  // namespace

KabschResult estimate_rigid_transform(const std::vector<Eigen::Vector3d>& source,
                                      const std::vector<Eigen::Vector3d>& target,
                                      const std::vector<double>& weights) {
    if (source.size() != target.size() || (!weights.empty() && weights.size() != source.size())) {
        return {};
    }
    return solve(source.size(), [&](std::size_t i) {
        return Pair{source[i], target[i], weights.empty() ? 1.0 : weights[i]};
    });
}

KabschResult estimate_rigid_transform(const std::vector<Eigen::Vector3d>& source_points,
                                      const std::vector<Eigen::Vector3d>& target_points,
                                      const Correspondences& correspondences,
                                      const std::vector<std::uint32_t>& subset) {
    const std::size_t n = subset.empty() ? correspondences.size() : subset.size();
    for (std::size_t i = 0; i < n; ++i) {
        if (!subset.empty() && subset[i] >= correspondences.size()) return {};
        const Correspondence& c = correspondences[subset.empty() ? i : subset[i]];
        if (c.source >= source_points.size() || c.target >= target_points.size()) return {};
    }
    return solve(n, [&](std::size_t i) {
        const Correspondence& c = correspondences[subset.empty() ? i : subset[i]];
        return Pair{source_points[c.source], target_points[c.target], 1.0};
    });
}

}  // namespace lidarfuse::core
