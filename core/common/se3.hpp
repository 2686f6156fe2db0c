#pragma once
// SE(3) / SO(3) helpers on Eigen::Isometry3d.
//
// Tangent-vector convention used everywhere in lidarfuse (G-ICP Hessian, pose-graph edge
// information): a 6-vector xi = [omega; v], rotation first (radians), then translation
// (metres). Perturbations are applied on the right: T * se3_exp(xi), i.e. xi is expressed
// in the frame of T's source (the "body" frame). A 6x6 information matrix from G-ICP is in
// exactly this order and frame.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace lidarfuse::core {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// [v]x: the matrix with [v]x * w = v.cross(w).
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

// Rodrigues' formula; exact for any angle, Taylor-expanded below ~1e-6 rad (no 0/0).
Eigen::Matrix3d so3_exp(const Eigen::Vector3d& omega_rad);
// Inverse of so3_exp, angle in [0, pi]; stable near 0 and near pi. The input must be a
// rotation matrix (orthonormal, det +1).
Eigen::Vector3d so3_log(const Eigen::Matrix3d& R);

// exp of [omega; v]: R = so3_exp(omega), t = V(omega) * v (V = left Jacobian of SO(3)).
Eigen::Isometry3d se3_exp(const Vector6d& xi);
// Inverse of se3_exp.
Vector6d se3_log(const Eigen::Isometry3d& T);

// Angle (radians, 0..pi) of the rotation R_a * R_b^T; robust near 0 (atan2 form, no acos
// clamp loss).
double rotation_angle_rad(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b);
double rotation_angle_deg(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b);

// Errors of an estimate against a reference pose: |t_est - t_ref| (m) and the rotation
// angle between them (rad / deg).
double translation_error_m(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_ref);
double rotation_error_rad(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_ref);
double rotation_error_deg(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_ref);

// Isometry from a (not necessarily normalised) quaternion and a translation.
Eigen::Isometry3d isometry_from_quaternion(const Eigen::Quaterniond& q, const Eigen::Vector3d& t_m);
// The rotation of T as a unit quaternion with w >= 0 (canonical sign).
Eigen::Quaterniond quaternion_of(const Eigen::Isometry3d& T);

// Re-orthonormalises the rotation part (nearest rotation via SVD, det +1). Use after long
// chains of products.
Eigen::Isometry3d orthonormalized(const Eigen::Isometry3d& T);

// Mean pose: arithmetic mean of translations, Karcher (geodesic) mean of rotations by
// fixed-point iteration in the tangent space (rotations must lie within pi/2 of each
// other for a unique answer). Empty input: identity.
Eigen::Isometry3d average_poses(const std::vector<Eigen::Isometry3d>& poses,
                                int max_iterations = 20);

}  // namespace lidarfuse::core
