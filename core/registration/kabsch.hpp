#pragma once
// Least-squares rigid transform between paired points (Kabsch 1976; Umeyama 1991 without
// scale): finds R, t minimising sum_i w_i |R * source_i + t - target_i|^2 by an SVD of the
// weighted cross-covariance. A reflection (det < 0) is fixed by flipping the sign of the
// smallest singular direction, so the result is always a proper rotation.

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/registration/correspondence.hpp"

namespace lidarfuse::core {

struct KabschResult {
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    // False when fewer than 3 pairs were given or the source points are (nearly)
    // collinear, so that the rotation about their line is undetermined.
    bool valid = false;
    // Root-mean-square residual |T * source_i - target_i| after the fit (m).
    double rms_error_m = 0.0;
};

// Paired arrays: source[i] corresponds to target[i]. `weights` may be empty (all 1).
KabschResult estimate_rigid_transform(const std::vector<Eigen::Vector3d>& source,
                                      const std::vector<Eigen::Vector3d>& target,
                                      const std::vector<double>& weights = {});

// Pairs given as correspondences into two point arrays; only `subset` (indices into
// `correspondences`) is used, or all of them when `subset` is empty.
KabschResult estimate_rigid_transform(const std::vector<Eigen::Vector3d>& source_points,
                                      const std::vector<Eigen::Vector3d>& target_points,
                                      const Correspondences& correspondences,
                                      const std::vector<std::uint32_t>& subset = {});

}  // namespace lidarfuse::core
