#include "drivers/sim/pendulum.hpp"

#include <algorithm>
#include <cmath>

#include "drivers/sim/rng.hpp"

namespace lidarfuse::sim {

namespace {

// Time derivative of (u, u').
PendulumState derivative(const PendulumState& s, const PendulumParams& p) {
    const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
    PendulumState d;
    d.u = s.u_dot;
    d.u_dot = (p.gravity_mps2 / p.length_m) * (ez - s.u.z() * s.u) - s.u_dot.squaredNorm() * s.u;
    return d;
}

PendulumState add(const PendulumState& s, const PendulumState& d, double h) {
    return {s.u + h * d.u, s.u_dot + h * d.u_dot};
}

}  // namespace

PendulumState state_from_spherical(const PendulumInit& in) {
    const double st = std::sin(in.theta), ct = std::cos(in.theta);
    const double sp = std::sin(in.phi), cp = std::cos(in.phi);
    PendulumState s;
    s.u = Eigen::Vector3d(st * cp, st * sp, ct);
    s.u_dot = in.theta_dot * Eigen::Vector3d(ct * cp, ct * sp, -st) +
              in.phi_dot * st * Eigen::Vector3d(-sp, cp, 0.0);
    return s;
}

PendulumState rk4_step(const PendulumState& s, double dt, const PendulumParams& p) {
    const PendulumState k1 = derivative(s, p);
    const PendulumState k2 = derivative(add(s, k1, dt / 2), p);
    const PendulumState k3 = derivative(add(s, k2, dt / 2), p);
    const PendulumState k4 = derivative(add(s, k3, dt), p);
    PendulumState out;
    out.u = s.u + dt / 6 * (k1.u + 2 * k2.u + 2 * k3.u + k4.u);
    out.u_dot = s.u_dot + dt / 6 * (k1.u_dot + 2 * k2.u_dot + 2 * k3.u_dot + k4.u_dot);
    out.u.normalize();
    out.u_dot -= out.u.dot(out.u_dot) * out.u;
    return out;
}

double pendulum_energy(const PendulumState& s, const PendulumParams& p) {
    return 0.5 * p.length_m * p.length_m * s.u_dot.squaredNorm() -
           p.gravity_mps2 * p.length_m * s.u.z();
}

PendulumTrajectory::PendulumTrajectory(const PendulumInit& init, double duration_s,
                                       const PendulumParams& params)
    : params_(params) {
    const auto steps = static_cast<std::size_t>(std::ceil(duration_s / params.step_s)) + 2;
    states_.reserve(steps);
    states_.push_back(state_from_spherical(init));
    while (states_.size() < steps)
        states_.push_back(rk4_step(states_.back(), params.step_s, params));
}

PendulumState PendulumTrajectory::sample(double t_s) const {
    const double x = std::clamp(t_s / params_.step_s, 0.0, static_cast<double>(states_.size() - 1));
    const auto i = std::min(static_cast<std::size_t>(x), states_.size() - 2);
    const double a = x - static_cast<double>(i), h = params_.step_s;
    const PendulumState& s0 = states_[i];
    const PendulumState& s1 = states_[i + 1];
    // Cubic Hermite basis and its derivative.
    const double a2 = a * a, a3 = a2 * a;
    const double h00 = 2 * a3 - 3 * a2 + 1, h10 = a3 - 2 * a2 + a, h01 = -2 * a3 + 3 * a2,
                 h11 = a3 - a2;
    const double d00 = (6 * a2 - 6 * a) / h, d10 = 3 * a2 - 4 * a + 1, d01 = (-6 * a2 + 6 * a) / h,
                 d11 = 3 * a2 - 2 * a;
    PendulumState out;
    out.u = (h00 * s0.u + h10 * h * s0.u_dot + h01 * s1.u + h11 * h * s1.u_dot).normalized();
    out.u_dot = d00 * s0.u + d10 * s0.u_dot + d01 * s1.u + d11 * s1.u_dot;
    return out;
}

Eigen::Quaterniond PendulumTrajectory::tilt(double t_s) const {
    return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), sample(t_s).u);
}

PendulumInit draw_pendulum_init(std::uint64_t seed, int sensor_index) {
    CounterRng rng(seed, 0x70656E64756CULL /* "pendul" */,
                   static_cast<std::uint64_t>(sensor_index));
    PendulumInit init;
    init.phi = rng.uniform(0.0, 0.7 * M_PI);
    init.phi_dot = rng.uniform(-0.2 * M_PI, 0.2 * M_PI);
    init.theta = rng.uniform(-0.02 * M_PI, 0.02 * M_PI);
    init.theta_dot = rng.uniform(-0.01 * M_PI, 0.01 * M_PI);
    return init;
}

}  // namespace lidarfuse::sim
