#pragma once
// A sensor's pose carried ahead of its registered poses, for a frame fused without
// registration (FrameMode::kPredict). The registered poses T_i (times t_i, oldest first) are
// taken into the tangent space of the newest, x_i = log(T_last^-1 T_i) at
// tau_i = t_i - t_last (s, <= 0), and a polynomial in tau with an intercept,
//   x(tau) = c + v tau               (order 1: constant velocity)
//   x(tau) = c + v tau + a tau^2 / 2 (order 2: constant acceleration),
// is fitted to them by least squares; the pose at t is T_last exp(x(t - t_last)).
// The intercept lets the fit average the newest pose's registration noise too. A swaying
// pole accelerates all the time, so over more than a frame period a constant velocity
// misses by a * h^2 / 2; the errors of both orders on the simulator's three scenes, by the
// spacing and number of poses and the horizon: bench/BENCHMARK.md, "How far ahead a pose
// can be predicted".

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace lidarfuse::core {

struct PoseSample {
    std::int64_t frame = 0;
    std::int64_t t_ns = 0;
    Eigen::Isometry3d T_root_sensor = Eigen::Isometry3d::Identity();
};

// The fitted pose at t_ns from `poses` (oldest first, distinct times; at least order + 1 of
// them, else the newest pose as it is).
Eigen::Isometry3d extrapolate_pose(const std::vector<PoseSample>& poses, std::int64_t t_ns,
                                   int order);

}  // namespace lidarfuse::core
