#pragma once
// The point-to-point error metric the paper scores candidate transforms with (PAPER.md,
// initial registration step 8; Lehtola et al. 2017 with p = 2):
//   E = sqrt( (1/N) * sum_i w_i |u_i - v_i|^2 ),
// u_i = T_target_source * (source point i), v_i its nearest neighbor in the target,
// w_i = 1 if |u_i - v_i| <= r_c else 0, N = number of source points with w_i = 1.
// Also reports N and the overlap share N / |source|. Units: metres.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "core/common/kdtree.hpp"

namespace lidarfuse::core {

struct P2pErrorParams {
    double cutoff_radius_m = 1.0;  // r_c; the paper: ~ the largest downsampling voxel size
};

struct P2pErrorResult {
    bool valid = false;                 // N > 0 (otherwise error_m is 0 and meaningless)
    double error_m = 0.0;               // E
    std::size_t num_within_cutoff = 0;  // N
    std::size_t num_source = 0;
    double overlap_share = 0.0;  // N / num_source
};

// `target_tree` is a k-d tree over the target points (frame: target).
P2pErrorResult p2p_error(const std::vector<Eigen::Vector3d>& source_points,
                         const KdTree& target_tree, const Eigen::Isometry3d& T_target_source,
                         const P2pErrorParams& params = {}, int num_threads = 1);

}  // namespace lidarfuse::core
