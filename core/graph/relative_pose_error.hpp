#pragma once
// The pose-graph residual: disagreement between a measured relative pose and two nodes.
//
// Nodes a and b are T_world_a = (q_a, t_a), T_world_b = (q_b, t_b) (unit quaternions in
// Eigen's x, y, z, w memory order, translations in metres). The measurement is
// Z = T_a_b (e.g. G-ICP's T_target_source with a = target, b = source) with a 6x6
// information matrix Omega in se3.hpp's tangent order [omega; v].
//
// G-ICP's Hessian is the information of a right perturbation of its estimate:
// T_true = Z * exp(delta), delta ~ N(0, Omega^-1). The matching error is therefore
//   E = Z^-1 * T_a^-1 * T_b = exp(delta)                      (identity when consistent)
//   q_E = q_Z^* (q_a^* q_b),   t_E = R_Z^T (R_a^T (t_b - t_a) - t_Z)
// and, to first order, delta = [2 vec(q_E); t_E] (exp(delta) ~ (I + [omega]x, v); the
// quaternion of a rotation by angle |omega| has vec = sin(|omega|/2) omega/|omega|).
// q_E is taken with w >= 0 so that the residual is continuous across the double cover.
// The whitened residual is r = S * delta with S = L^T from the Cholesky factorisation
// Omega = L L^T (so |r|^2 = delta^T Omega delta), computed once per edge. A Huber loss
// on |r|^2 then acts in units of standard deviations.

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/se3.hpp"

namespace lidarfuse::core {

class RelativePoseError {
public:
    RelativePoseError(const Eigen::Isometry3d& T_a_b, const Matrix6d& sqrt_information)
        : q_a_b_(Eigen::Quaterniond(T_a_b.linear()).normalized()),
          t_a_b_(T_a_b.translation()),
          sqrt_information_(sqrt_information) {}

    template <typename T>
    bool operator()(const T* q_a_ptr, const T* t_a_ptr, const T* q_b_ptr, const T* t_b_ptr,
                    T* residual_ptr) const {
        const Eigen::Map<const Eigen::Quaternion<T>> q_a(q_a_ptr);
        const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_a(t_a_ptr);
        const Eigen::Map<const Eigen::Quaternion<T>> q_b(q_b_ptr);
        const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_b(t_b_ptr);

        const Eigen::Quaternion<T> q_a_inv = q_a.conjugate();
        const Eigen::Quaternion<T> q_ab_est = q_a_inv * q_b;
        const Eigen::Matrix<T, 3, 1> t_ab_est = q_a_inv * (t_b - t_a);

        const Eigen::Quaternion<T> q_z_inv = q_a_b_.conjugate().template cast<T>();
        Eigen::Quaternion<T> q_e = q_z_inv * q_ab_est;
        const Eigen::Matrix<T, 3, 1> t_e = q_z_inv * (t_ab_est - t_a_b_.template cast<T>());
        if (q_e.w() < T(0)) q_e.coeffs() = -q_e.coeffs();

        Eigen::Matrix<T, 6, 1> delta;
        delta.template head<3>() = T(2.0) * q_e.vec();
        delta.template tail<3>() = t_e;
        Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(residual_ptr);
        residual = sqrt_information_.template cast<T>() * delta;
        return true;
    }

    // The Problem does not own it (PoseGraph does); parameter blocks: q_a(4), t_a(3),
    // q_b(4), t_b(3).
    static ceres::CostFunction* create(const Eigen::Isometry3d& T_a_b,
                                       const Matrix6d& sqrt_information) {
        return new ceres::AutoDiffCostFunction<RelativePoseError, 6, 4, 3, 4, 3>(
            new RelativePoseError(T_a_b, sqrt_information));
    }

private:
    Eigen::Quaterniond q_a_b_;
    Eigen::Vector3d t_a_b_;
    Matrix6d sqrt_information_;
};

}  // namespace lidarfuse::core
