#pragma once
// Pole sway: each pole head is a spherical pendulum with inverted gravity (PAPER.md,
// "Sensor motion"): r = 6 m, restoring towards the upright position. The paper states it
// in spherical angles,
//   theta'' = phi'^2 sin(theta) cos(theta) - (g/r) sin(theta)
//   phi''   = -2 phi' theta' cos(theta) / sin(theta),
// which is singular at theta = 0 (the upright rest position). We integrate the same motion
// in unit-vector form instead: u = head direction from the pole base (|u| = 1),
//   u'' = (g/r) (e_z - (e_z . u) u) - |u'|^2 u,
// i.e. the tangential part of an upward "gravity" plus the centripetal term that keeps
// |u| = 1. RK4 at a fixed step (1 ms by default), then u is renormalised and u' projected
// onto the tangent plane (removes the O(dt^5) constraint drift). Energy per unit mass:
//   E = r^2 |u'|^2 / 2 - g r u_z.
// Samples are stored at every step; sample(t) interpolates with cubic Hermite polynomials
// (u and u' known at both ends), so columns between steps get smooth poses.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace lidarfuse::sim {

// Initial values in the paper's spherical form (radians, radians per second).
struct PendulumInit {
    double theta = 0;
    double theta_dot = 0;
    double phi = 0;
    double phi_dot = 0;
};

struct PendulumParams {
    double length_m = 6.0;
    double gravity_mps2 = 9.81;
    double step_s = 1e-3;
};

struct PendulumState {
    Eigen::Vector3d u = Eigen::Vector3d::UnitZ();     // unit direction base -> head
    Eigen::Vector3d u_dot = Eigen::Vector3d::Zero();  // 1/s
};

PendulumState state_from_spherical(const PendulumInit& init);
// One RK4 step of length dt_s, followed by the constraint projection.
PendulumState rk4_step(const PendulumState& s, double dt_s, const PendulumParams& params);
double pendulum_energy(const PendulumState& s, const PendulumParams& params);

// A precomputed trajectory over [0, duration_s].
class PendulumTrajectory {
public:
    PendulumTrajectory(const PendulumInit& init, double duration_s,
                       const PendulumParams& params = {});
    // State at time t_s (clamped to [0, duration]); cubic Hermite between steps.
    PendulumState sample(double t_s) const;
    // Rotation that tilts the upright pole onto u(t): the minimal rotation e_z -> u.
    Eigen::Quaterniond tilt(double t_s) const;
    const PendulumParams& params() const { return params_; }
    const std::vector<PendulumState>& states() const { return states_; }

private:
    PendulumParams params_;
    std::vector<PendulumState> states_;
};

// Draws initial values per sensor from PAPER.md's ranges: phi in [0, 0.7 pi],
// phi' in [-0.2 pi, 0.2 pi], theta in [-0.02 pi, 0.02 pi], theta' in [-0.01 pi, 0.01 pi].
PendulumInit draw_pendulum_init(std::uint64_t seed, int sensor_index);

}  // namespace lidarfuse::sim
