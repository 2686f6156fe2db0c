#include "core/common/smallest_eigenvector.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <optional>

namespace lidarfuse::core {

namespace {

// Newton's steps to l0 before the solver answers instead; 2-4 on a surface's covariance.
constexpr int kMaxNewtonSteps = 12;
// Newton has settled when a step is below this share of the trace: one more step then
// squares the error (quadratic convergence at a simple root).
constexpr double kSettledStep = 1e-9;
// u0 from cross products is trusted when l1 - l0 is at least this share of l2: its
// rounding error is about the machine epsilon over this share, 1e-9 rad at the bound.
constexpr double kMinRelativeGap = 1e-7;

SmallestEigenvector from_solver(const Eigen::Matrix3d& c) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.computeDirect(c);
    return {solver.eigenvalues(), solver.eigenvectors().col(0)};
}

// The smallest root of l^3 - t l^2 + m l - d, by Newton's method from 0 (see the header);
// nullopt when it does not settle (a double root converges only linearly).
std::optional<double> smallest_root(double t, double m, double d) {
    if (!(t > 0) || !(m > 0)) return std::nullopt;
    double l = 0.0;
    bool settled = false;
    for (int step = 0; step < kMaxNewtonSteps; ++step) {
        const double f = ((l - t) * l + m) * l - d;
        const double slope = (3.0 * l - 2.0 * t) * l + m;
        if (!(slope > 0)) return std::nullopt;
        const double delta = f / slope;
        l -= delta;
        if (settled) return l;
        settled = std::abs(delta) <= kSettledStep * t;
    }
    return std::nullopt;
}

// The longest cross product of two rows of C - l0 I (all parallel to u0), normalised;
// nullopt when every one is zero.
std::optional<Eigen::Vector3d> kernel_axis(const Eigen::Matrix3d& c, double l0) {
    Eigen::Matrix3d shifted = c;
    shifted.diagonal().array() -= l0;
    const Eigen::Vector3d r0 = shifted.col(0), r1 = shifted.col(1), r2 = shifted.col(2);
    const Eigen::Vector3d a = r0.cross(r1), b = r0.cross(r2), e = r1.cross(r2);
    const double na = a.squaredNorm(), nb = b.squaredNorm(), ne = e.squaredNorm();
    const double longest = std::max(na, std::max(nb, ne));
    if (!(longest > 0)) return std::nullopt;
    const Eigen::Vector3d& axis = longest == na ? a : longest == nb ? b : e;
    return axis / std::sqrt(longest);
}

}  // namespace

SmallestEigenvector smallest_eigenvector(const Eigen::Matrix3d& c) {
    const double t = c.trace();
    const double m = c(0, 0) * c(1, 1) - c(0, 1) * c(0, 1) + c(0, 0) * c(2, 2) - c(0, 2) * c(0, 2) +
                     c(1, 1) * c(2, 2) - c(1, 2) * c(1, 2);
    const double d = c.determinant();
    const std::optional<double> l0 = smallest_root(t, m, d);
    if (!l0) return from_solver(c);
    // What is left: l1 + l2 = t - l0 and l1 l2 = m - l0 (t - l0); l1 as the product over
    // l2, which keeps its precision when it is small.
    const double sum = t - *l0;
    const double product = m - *l0 * sum;
    const double l2 = 0.5 * (sum + std::sqrt(std::max(0.0, sum * sum - 4.0 * product)));
    const double l1 = l2 > 0 ? product / l2 : 0.0;
    if (!(l1 - *l0 >= kMinRelativeGap * l2)) return from_solver(c);
    const std::optional<Eigen::Vector3d> axis = kernel_axis(c, *l0);
    if (!axis) return from_solver(c);
    return {Eigen::Vector3d(*l0, l1, l2), *axis};
}

}  // namespace lidarfuse::core
