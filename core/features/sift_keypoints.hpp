#pragma once
// 3-D SIFT keypoints on surface curvature (PAPER.md step 4; Lowe's scale-space extrema,
// as PCL's SIFTKeypoint does with curvature as the intensity). For every octave o the
// cloud is voxel-averaged at the octave's base scale s_o = min_scale_m * 2^o (points and
// curvature). On that cloud, curvature is smoothed at scales
//   sigma_{o,k} = s_o * 2^(k / scales_per_octave),  k = 0 .. scales_per_octave + 2,
// by a Gaussian-weighted mean over the neighbors within 2.5 sigma, and differences of
// adjacent scales (DoG_k = L_{k+1} - L_k) are formed. A point is a keypoint at
// k = 1 .. scales_per_octave when its DoG_k is a strict maximum or minimum among its
// neighbors within 1.75 s_o at DoG_{k-1}, DoG_k and DoG_{k+1} (itself included at k-1, k+1),
// and |DoG_k| >= min_contrast. Keypoints are reported as indices of the nearest input
// point (deduplicated, ascending), so descriptors can be computed at them.
//
// Flat regions have constant curvature, hence no DoG response. Deterministic; parallel
// over points (OpenMP, `num_threads`).

#include <cstdint>
#include <vector>

#include "core/common/point_cloud.hpp"

namespace lidarfuse::core {

struct SiftKeypointParams {
    // Base scale of the first octave (m): smoothing sigma and voxel size of octave 0.
    double min_scale_m = 0.5;
    int octaves = 3;
    int scales_per_octave = 3;
    // Minimum |DoG| of curvature (curvature is lambda_min / sum(lambda), in [0, 1/3]).
    double min_contrast = 0.001;
    // Octave clouds with fewer points than this end the pyramid.
    int min_points_per_octave = 16;
};

struct SiftKeypointResult {
    // Indices into the input points, ascending and unique.
    std::vector<std::uint32_t> indices;
    // Scale (sigma, m) at which each keypoint was found (the smallest, when several).
    std::vector<float> scale_m;
};

// `points` with one `curvature` value each (sizes must match, else no keypoints).
SiftKeypointResult detect_sift_keypoints(const std::vector<Eigen::Vector3d>& points,
                                         const std::vector<double>& curvature,
                                         const SiftKeypointParams& params = {},
                                         int num_threads = 1);

}  // namespace lidarfuse::core
