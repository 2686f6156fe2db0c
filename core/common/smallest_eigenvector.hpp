#pragma once
// The eigenvalues of a symmetric positive semi-definite 3x3 matrix (a neighbourhood's
// covariance) and the unit eigenvector of the smallest one (the surface normal), which is
// all that the covariance pass needs of the decomposition (normals.hpp: the plane
// covariance I - (1 - epsilon) u0 u0^T, the normal, the curvature).
//
// With t = tr C, m = the sum of C's principal 2x2 minors and d = det C, the eigenvalues
// are the roots of f(l) = l^3 - t l^2 + m l - d. Below t / 3 f is concave and increasing,
// so Newton's method from l = 0 (at or below l0 for a positive semi-definite C) climbs to
// l0 without overshooting, in 2-4 steps when l0 is well apart from l1, as on a surface.
// l1 and l2 then follow from the quadratic that is left (sum t - l0, product
// m - l0 (t - l0)). Every row of C - l0 I lies in the span of u1 and u2, so the cross
// product of two rows is parallel to u0; the longest of the three is taken.
//
// Where u0 is not well defined that way (l1 - l0 below 1e-7 l2: a line, an isotropic
// blob, a single point) or Newton does not settle in a few steps, Eigen's
// SelfAdjointEigenSolver::computeDirect answers instead, which orthogonalises u0 against
// the most distinct axis. Elsewhere the two agree to rounding (|u0 . u0'| within 1e-12
// of 1, eigenvalues within 1e-11 l2, as smallest_eigenvector_test.cpp holds them); u0's
// sign is either.

#include <Eigen/Core>

namespace lidarfuse::core {

struct SmallestEigenvector {
    Eigen::Vector3d eigenvalues;  // ascending, in C's units
    Eigen::Vector3d axis;         // unit eigenvector of eigenvalues(0)
};

SmallestEigenvector smallest_eigenvector(const Eigen::Matrix3d& covariance);

}  // namespace lidarfuse::core
