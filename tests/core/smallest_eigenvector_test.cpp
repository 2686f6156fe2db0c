#include "core/common/smallest_eigenvector.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

namespace lidarfuse::core {
namespace {

// The covariance of k points spread by sigma_a, sigma_b and sigma_n along three orthogonal
// axes (n the normal), centred far from the origin as a sensor's points are.
Eigen::Matrix3d neighbourhood(std::mt19937* rng, int k, double sigma_a, double sigma_b,
                              double sigma_n) {
    std::normal_distribution<double> g(0.0, 1.0);
    const Eigen::Vector3d n = Eigen::Vector3d(g(*rng), g(*rng), g(*rng)).normalized();
    const Eigen::Vector3d a = n.unitOrthogonal(), b = n.cross(a);
    const Eigen::Vector3d centre(41.3, -17.9, 2.4);
    std::vector<Eigen::Vector3d> points;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int j = 0; j < k; ++j) {
        points.push_back(centre + a * sigma_a * g(*rng) + b * sigma_b * g(*rng) +
                         n * sigma_n * g(*rng));
        mean += points.back();
    }
    mean /= k;
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    for (const auto& p : points) c += (p - mean) * (p - mean).transpose();
    return c / k;
}

Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solved(const Eigen::Matrix3d& c) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.compute(c);  // the iterative (QL) solver: an independent reference
    return solver;
}

void expect_matches_reference(const Eigen::Matrix3d& c) {
    const auto reference = solved(c);
    const SmallestEigenvector e = smallest_eigenvector(c);
    const double l2 = reference.eigenvalues()(2);
    for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(e.eigenvalues(k), reference.eigenvalues()(k), 1e-11 * l2);
    EXPECT_NEAR(e.axis.norm(), 1.0, 1e-14);
    EXPECT_NEAR(std::abs(e.axis.dot(reference.eigenvectors().col(0))), 1.0, 1e-12) << c;
}

TEST(SmallestEigenvector, SurfacesOfEveryShapeMatchTheIterativeSolver) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> spread(0.05, 1.0);
    for (int i = 0; i < 2000; ++i) {
        // Planes, thin and thick, round and elongated (l2 up to 400 l1), 3 to 20 points.
        const int k = 3 + i % 18;
        const double sa = spread(rng), sb = spread(rng) * spread(rng);
        const double sn = 0.03 * spread(rng) * std::min(sa, sb);
        if (k == 3) continue;  // three points span a plane exactly: l0 is 0 (below)
        expect_matches_reference(neighbourhood(&rng, k, sa, sb, sn));
    }
}

TEST(SmallestEigenvector, AxisAlignedSurfacesAsTheGroundAndWalls) {
    // A normal along a coordinate axis zeroes a row of C - l0 I (and the cross products
    // with it): the ground (z), walls facing x and y.
    for (int k = 0; k < 3; ++k) {
        Eigen::Vector3d spread(0.8, 0.3, 0.5);
        spread(k) = 2e-4;
        const Eigen::Matrix3d c = spread.asDiagonal();
        const SmallestEigenvector e = smallest_eigenvector(c);
        EXPECT_NEAR(std::abs(e.axis(k)), 1.0, 1e-15) << "normal along axis " << k;
        EXPECT_NEAR(e.eigenvalues(0), 2e-4, 1e-16);
        expect_matches_reference(c);
    }
}

TEST(SmallestEigenvector, ScaleDoesNotMatter) {
    std::mt19937 rng(11);
    const Eigen::Matrix3d c = neighbourhood(&rng, 8, 0.7, 0.3, 0.01);
    for (double scale : {1e-12, 1e-6, 1.0, 1e6, 1e12}) expect_matches_reference(c * scale);
}

TEST(SmallestEigenvector, ExactPlaneHasAZeroEigenvalueAndItsNormal) {
    // Four points on the plane z = 2x: the normal is (2, 0, -1) / sqrt(5).
    const Eigen::Vector3d p[4] = {{0, 0, 0}, {1, 0, 2}, {0, 1, 0}, {1, 1, 2}};
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& q : p) mean += q / 4;
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    for (const auto& q : p) c += (q - mean) * (q - mean).transpose() / 4;
    const SmallestEigenvector e = smallest_eigenvector(c);
    EXPECT_NEAR(e.eigenvalues(0), 0.0, 1e-15);
    EXPECT_NEAR(std::abs(e.axis.dot(Eigen::Vector3d(2, 0, -1).normalized())), 1.0, 1e-14);
    expect_matches_reference(c);
}

TEST(SmallestEigenvector, AxisIsOrthogonalToALineAndDefinedForDegenerateInput) {
    // A line along (1, 1, 0): l0 = l1 = 0, any unit axis orthogonal to the line will do.
    Eigen::Matrix3d line = Eigen::Matrix3d::Zero();
    line.topLeftCorner<2, 2>().setConstant(0.5);
    SmallestEigenvector e = smallest_eigenvector(line);
    EXPECT_NEAR(e.axis.norm(), 1.0, 1e-14);
    EXPECT_NEAR(e.axis.dot(Eigen::Vector3d(1, 1, 0).normalized()), 0.0, 1e-12);
    EXPECT_NEAR(e.eigenvalues(2), 1.0, 1e-14);

    // A nearly straight line (l1 just above l0): still orthogonal to it.
    std::mt19937 rng(3);
    const Eigen::Matrix3d thin = neighbourhood(&rng, 10, 1.0, 1e-9, 1e-10);
    const auto reference = solved(thin);
    e = smallest_eigenvector(thin);
    EXPECT_NEAR(e.axis.dot(reference.eigenvectors().col(2)), 0.0, 1e-9);

    // Isotropic, a single point (zero) and not finite: a unit axis, the solver's answer.
    for (const Eigen::Matrix3d& c : {Eigen::Matrix3d(Eigen::Matrix3d::Identity() * 0.25),
                                     Eigen::Matrix3d(Eigen::Matrix3d::Zero())}) {
        e = smallest_eigenvector(c);
        EXPECT_NEAR(e.axis.norm(), 1.0, 1e-14);
        EXPECT_NEAR(e.eigenvalues(0), c(0, 0), 1e-15);
        EXPECT_NEAR(e.eigenvalues(2), c(0, 0), 1e-15);
    }
    Eigen::Matrix3d bad = Eigen::Matrix3d::Identity();
    bad(1, 1) = std::nan("");
    e = smallest_eigenvector(bad);  // the solver's answer: not a finite one made up
    EXPECT_FALSE(e.eigenvalues.allFinite());
}

}  // namespace
}  // namespace lidarfuse::core
