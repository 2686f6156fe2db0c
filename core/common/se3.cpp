#include "core/common/se3.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace lidarfuse::core {

namespace {
// Below this angle (rad) the closed forms lose precision to cancellation; the Taylor series
// truncated after the quadratic term are exact to double precision there.
constexpr double kSmallAngleRad = 1e-5;
}  // namespace

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
    Eigen::Matrix3d m;
    m << 0.0, -v.z(), v.y(),  //
        v.z(), 0.0, -v.x(),   //
        -v.y(), v.x(), 0.0;
    return m;
}

Eigen::Matrix3d so3_exp(const Eigen::Vector3d& omega_rad) {
    const double theta2 = omega_rad.squaredNorm();
    const double theta = std::sqrt(theta2);
    const Eigen::Matrix3d W = skew(omega_rad);
    double a, b;  // R = I + a W + b W^2
    if (theta < kSmallAngleRad) {
        a = 1.0 - theta2 / 6.0;
        b = 0.5 - theta2 / 24.0;
    } else {
        a = std::sin(theta) / theta;
        b = (1.0 - std::cos(theta)) / theta2;
    }
    return Eigen::Matrix3d::Identity() + a * W + b * W * W;
}

Eigen::Vector3d so3_log(const Eigen::Matrix3d& R) {
    // Through the unit quaternion: Eigen's matrix-to-quaternion conversion picks the
    // largest diagonal pivot, so it stays accurate near pi where the trace form fails.
    Eigen::Quaterniond q(R);
    q.normalize();
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();
    const double n = q.vec().norm();
    const double w = q.w();
    double scale;  // omega = scale * q.vec(), angle = 2 atan2(n, w)
    if (n < 1e-10) {
        // 2 atan(n / w) / n = 2 / w * (1 - n^2 / (3 w^2) + ...), w ~ 1 here.
        scale = 2.0 / w * (1.0 - n * n / (3.0 * w * w));
    } else {
        scale = 2.0 * std::atan2(n, w) / n;
    }
    return scale * q.vec();
}

namespace {
// Left Jacobian V of SO(3) and its inverse, used by se3_exp / se3_log.
Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& omega) {
    const double theta2 = omega.squaredNorm();
    const double theta = std::sqrt(theta2);
    const Eigen::Matrix3d W = skew(omega);
    double a, b;  // V = I + a W + b W^2
    if (theta < kSmallAngleRad) {
        a = 0.5 - theta2 / 24.0;
        b = 1.0 / 6.0 - theta2 / 120.0;
    } else {
        a = (1.0 - std::cos(theta)) / theta2;
        b = (theta - std::sin(theta)) / (theta2 * theta);
    }
    return Eigen::Matrix3d::Identity() + a * W + b * W * W;
}

Eigen::Matrix3d left_jacobian_inverse(const Eigen::Vector3d& omega) {
    const double theta2 = omega.squaredNorm();
    const double theta = std::sqrt(theta2);
    const Eigen::Matrix3d W = skew(omega);
    double c;  // V^-1 = I - W / 2 + c W^2
    if (theta < kSmallAngleRad) {
        c = 1.0 / 12.0 + theta2 / 720.0;
    } else {
        c = (1.0 - theta * std::sin(theta) / (2.0 * (1.0 - std::cos(theta)))) / theta2;
    }
    return Eigen::Matrix3d::Identity() - 0.5 * W + c * W * W;
}
}  // namespace

Eigen::Isometry3d se3_exp(const Vector6d& xi) {
    const Eigen::Vector3d omega = xi.head<3>();
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = so3_exp(omega);
    T.translation() = left_jacobian(omega) * xi.tail<3>();
    return T;
}

Vector6d se3_log(const Eigen::Isometry3d& T) {
    Vector6d xi;
    const Eigen::Vector3d omega = so3_log(T.linear());
    xi.head<3>() = omega;
    xi.tail<3>() = left_jacobian_inverse(omega) * T.translation();
    return xi;
}

double rotation_angle_rad(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b) {
    Eigen::Quaterniond q(R_a * R_b.transpose());
    return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
}

double rotation_angle_deg(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b) {
    return rotation_angle_rad(R_a, R_b) * 180.0 / EIGEN_PI;
}

double translation_error_m(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_ref) {
    return (T_est.translation() - T_ref.translation()).norm();
}

double rotation_error_rad(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_ref) {
    return rotation_angle_rad(T_est.linear(), T_ref.linear());
}

double rotation_error_deg(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_ref) {
    return rotation_angle_deg(T_est.linear(), T_ref.linear());
}

Eigen::Isometry3d isometry_from_quaternion(const Eigen::Quaterniond& q,
                                           const Eigen::Vector3d& t_m) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.normalized().toRotationMatrix();
    T.translation() = t_m;
    return T;
}

Eigen::Quaterniond quaternion_of(const Eigen::Isometry3d& T) {
    Eigen::Quaterniond q(T.linear());
    q.normalize();
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();
    return q;
}

Eigen::Isometry3d orthonormalized(const Eigen::Isometry3d& T) {
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(T.linear(), Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
    Eigen::Isometry3d out = T;
    out.linear() = svd.matrixU() * D * svd.matrixV().transpose();
    return out;
}

Eigen::Isometry3d average_poses(const std::vector<Eigen::Isometry3d>& poses, int max_iterations) {
    Eigen::Isometry3d mean = Eigen::Isometry3d::Identity();
    if (poses.empty()) return mean;
    Eigen::Vector3d t_sum = Eigen::Vector3d::Zero();
    for (const auto& T : poses) t_sum += T.translation();
    Eigen::Matrix3d R = poses.front().linear();
    for (int it = 0; it < max_iterations; ++it) {
        Eigen::Vector3d delta = Eigen::Vector3d::Zero();
        for (const auto& T : poses) delta += so3_log(R.transpose() * T.linear());
        delta /= static_cast<double>(poses.size());
        R = R * so3_exp(delta);
        if (delta.norm() < 1e-13) break;
    }
    mean.linear() = R;
    mean.translation() = t_sum / static_cast<double>(poses.size());
    return mean;
}

}  // namespace lidarfuse::core
