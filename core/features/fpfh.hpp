#pragma once
// Fast Point Feature Histograms (Rusu, Blodow, Beetz, ICRA 2009) at keypoints
// (PAPER.md step 4). For a pair of oriented points (p_s, n_s), (p_t, n_t) with
// d = p_t - p_s, the source is the one whose normal makes the smaller angle with the
// connecting line, and the Darboux frame u = n_s, v = u x d/|d|, w = u x v gives
//   alpha = v . n_t,  phi = u . d/|d|,  theta = atan2(w . n_t, u . n_t).
// SPFH(p): the three angles between p and each neighbor within `radius_m`, each binned
// into 11 bins over its range and normalised to sum 100.
// FPFH(p) = (SPFH(p) + sum_k w_k SPFH(p_k) / sum_k w_k) / 2 with w_k = 1 / |p - p_k|, so
// every 11-bin block of the 33-D descriptor sums to 100 (a point without neighbors gets
// an all-zero descriptor).
//
// Needs unit normals. The angles are invariant to rigid motions of the cloud, provided the
// normals move with it (same orientation convention in both clouds, e.g. towards the
// sensor). Parallel over keypoints (OpenMP, `num_threads`); deterministic.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/common/point_cloud.hpp"

namespace lidarfuse::core {

constexpr int kFpfhBinsPerAngle = 11;
constexpr int kFpfhSize = 3 * kFpfhBinsPerAngle;
using FpfhDescriptor = Eigen::Matrix<float, kFpfhSize, 1>;

struct FpfhParams {
    // Neighborhood radius for both the SPFH and the weighting step (m). Rusu suggests a
    // radius a few times the sampling distance.
    double radius_m = 3.0;
};

// Descriptors at `keypoints` (indices into `cloud`), in the same order. `cloud` must have
// normals; otherwise every descriptor is zero.
std::vector<FpfhDescriptor> compute_fpfh(const PointCloud& cloud,
                                         const std::vector<std::uint32_t>& keypoints,
                                         const FpfhParams& params = {}, int num_threads = 1);

// The three pair features (alpha, phi, theta) of Rusu's Darboux frame; false when the
// points coincide.
bool pair_features(const Eigen::Vector3d& p1, const Eigen::Vector3d& n1, const Eigen::Vector3d& p2,
                   const Eigen::Vector3d& n2, double* alpha, double* phi, double* theta);

}  // namespace lidarfuse::core
