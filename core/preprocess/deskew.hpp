#pragma once
// Per-point motion compensation ("deskew") of one sweep. lidarfuse adds this to the
// paper's method: a pole swaying at ~0.5 m/s moves 2.5 cm during a 50 ms sweep, which
// would otherwise smear every scan by as much as the accuracy we aim for.
//
// Model: over one sweep the sensor moves with a constant body-frame twist xi (se3.hpp
// order [omega; v], per second), so its pose at time t is T(t) = T(t_ref) exp(xi (t - t_ref)).
// A point p measured at t_k in the sensor frame of that instant is, in the sensor frame at
// t_ref:   p' = exp(xi * (t_k - t_ref)) * p.
// The engine takes the twist over the last three pose estimates (SensorTrack::deskew_twist:
// over one frame period the velocity fed back through the registration oscillates).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "core/common/se3.hpp"

namespace lidarfuse::core {

// Body twist (per second) that moves T_a to T_b in dt_s seconds: log(T_a^-1 T_b) / dt_s.
// Zero when dt_s <= 0.
Vector6d body_twist_per_s(const Eigen::Isometry3d& T_world_a, const Eigen::Isometry3d& T_world_b,
                          double dt_s);

// Moves every point from the sensor frame at its own time (t_ref + point_dt_s[i]) into the
// sensor frame at t_ref, in place. `point_dt_s` must have one entry per point. Points of
// one column share a time, so the transform is cached across equal consecutive dt values.
void deskew_points(const Vector6d& twist_per_s, const std::vector<float>& point_dt_s,
                   std::vector<Eigen::Vector3d>* points);

}  // namespace lidarfuse::core
