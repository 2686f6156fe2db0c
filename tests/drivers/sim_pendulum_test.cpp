// The pole-sway integrator (unit-vector form of the inverted spherical pendulum) against
// analytic properties: energy and angular momentum about z are conserved, the small-angle
// period is 2 pi sqrt(r / g), the upright rest state is an equilibrium, and passing
// through theta = 0 (singular in the paper's spherical form) is harmless.
#include <gtest/gtest.h>

#include <cmath>

#include "drivers/sim/pendulum.hpp"

namespace lidarfuse::sim {
namespace {

double lz(const PendulumState& s) { return s.u.x() * s.u_dot.y() - s.u.y() * s.u_dot.x(); }

TEST(SimPendulum, ConservesEnergyAndAngularMomentum) {
    const PendulumParams params;
    const PendulumInit init{0.05, 0.02, 0.3, 0.5};
    PendulumState s = state_from_spherical(init);
    const double e0 = pendulum_energy(s, params), l0 = lz(s);
    for (int i = 0; i < 60'000; ++i) s = rk4_step(s, params.step_s, params);  // 60 s
    EXPECT_NEAR(pendulum_energy(s, params), e0, 1e-9 * std::abs(e0));
    EXPECT_NEAR(lz(s), l0, 1e-9);
    EXPECT_NEAR(s.u.norm(), 1.0, 1e-12);
    EXPECT_NEAR(s.u.dot(s.u_dot), 0.0, 1e-12);
}

TEST(SimPendulum, SmallAnglePeriodMatchesTheAnalyticValue) {
    const PendulumParams params;  // r = 6 m, g = 9.81
    const double expected = 2 * M_PI * std::sqrt(params.length_m / params.gravity_mps2);
    PendulumTrajectory traj({1e-3, 0.0, 0.0, 0.0}, 30.0, params);
    // Upward zero crossings of u_x (planar swing in x-z), linearly interpolated.
    std::vector<double> crossings;
    const auto& st = traj.states();
    for (std::size_t i = 1; i < st.size(); ++i) {
        if (st[i - 1].u.x() < 0 && st[i].u.x() >= 0) {
            const double a = -st[i - 1].u.x() / (st[i].u.x() - st[i - 1].u.x());
            crossings.push_back((static_cast<double>(i - 1) + a) * params.step_s);
        }
    }
    ASSERT_GE(crossings.size(), 5u);
    const double period = (crossings.back() - crossings.front()) / (crossings.size() - 1);
    EXPECT_NEAR(period, expected, 1e-5 * expected);
    EXPECT_NEAR(expected, 4.914, 1e-3);
}

TEST(SimPendulum, UprightIsAnEquilibriumAndThetaZeroIsNotSingular) {
    const PendulumParams params;
    PendulumTrajectory rest({0, 0, 0, 0}, 5.0, params);
    EXPECT_EQ(rest.sample(4.9).u, Eigen::Vector3d::UnitZ());
    // Starts exactly upright with a push: passes through theta = 0 at t = 0 and again
    // every half period, without NaNs, and swings to the amplitude theta' / omega.
    PendulumTrajectory pushed({0, 0.01 * M_PI, 0.4, 0.3}, 20.0, params);
    const double omega = std::sqrt(params.gravity_mps2 / params.length_m);
    double max_theta = 0;
    for (const auto& s : pushed.states()) {
        ASSERT_TRUE(s.u.allFinite());
        max_theta = std::max(max_theta, std::acos(std::clamp(s.u.z(), -1.0, 1.0)));
    }
    EXPECT_NEAR(max_theta, 0.01 * M_PI / omega, 0.01 * 0.01 * M_PI / omega);
}

TEST(SimPendulum, HermiteSamplesAgreeWithFineIntegration) {
    PendulumParams coarse;
    PendulumParams fine;
    fine.step_s = 1e-5;
    const PendulumInit init{0.06, -0.03, 1.0, 0.4};
    PendulumTrajectory a(init, 2.0, coarse), b(init, 2.0, fine);
    for (double t : {0.0, 0.00049, 0.3337, 1.23456, 1.9999}) {
        EXPECT_LT((a.sample(t).u - b.sample(t).u).norm(), 1e-9) << t;
    }
}

TEST(SimPendulum, DrawnInitialValuesStayInThePapersRanges) {
    for (int k = 0; k < 64; ++k) {
        const PendulumInit init = draw_pendulum_init(7, k);
        EXPECT_GE(init.phi, 0.0);
        EXPECT_LE(init.phi, 0.7 * M_PI);
        EXPECT_LE(std::abs(init.phi_dot), 0.2 * M_PI);
        EXPECT_LE(std::abs(init.theta), 0.02 * M_PI);
        EXPECT_LE(std::abs(init.theta_dot), 0.01 * M_PI);
    }
    // Displacement of a 6 m pole head stays in the paper's "up to ~30 cm" regime.
    double max_disp = 0;
    for (int k = 0; k < 16; ++k) {
        PendulumTrajectory traj(draw_pendulum_init(1, k), 10.0);
        for (const auto& s : traj.states())
            max_disp = std::max(max_disp, 6.0 * s.u.head<2>().norm());
    }
    EXPECT_GT(max_disp, 0.1);
    EXPECT_LT(max_disp, 0.6);
}

}  // namespace
}  // namespace lidarfuse::sim
