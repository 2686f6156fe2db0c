#include "core/pipeline/pose_extrapolation.hpp"

#include <Eigen/Cholesky>

#include "core/common/se3.hpp"

namespace lidarfuse::core {

namespace {
constexpr double kSecondsPerNs = 1e-9;

// The fit's basis at tau (s): 1, tau and, for order 2, tau^2 / 2; unused rows zero.
Eigen::Vector3d basis(double tau, int order) {
    return Eigen::Vector3d(1.0, tau, order >= 2 ? 0.5 * tau * tau : 0.0);
}
}  // namespace

Eigen::Isometry3d extrapolate_pose(const std::vector<PoseSample>& poses, std::int64_t t_ns,
                                   int order) {
    if (poses.empty()) return Eigen::Isometry3d::Identity();
    const PoseSample& last = poses.back();
    if (order < 1 || poses.size() < static_cast<std::size_t>(order) + 1) return last.T_root_sensor;
    const Eigen::Isometry3d T_last_root = last.T_root_sensor.inverse();
    // Normal equations of the six tangent coordinates at once: one 3 x 3 system.
    Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
    Eigen::Matrix<double, 3, 6> normal_rhs = Eigen::Matrix<double, 3, 6>::Zero();
    for (const PoseSample& p : poses) {
        const Eigen::Vector3d row =
            basis(static_cast<double>(p.t_ns - last.t_ns) * kSecondsPerNs, order);
        normal_matrix += row * row.transpose();
        normal_rhs += row * se3_log(T_last_root * p.T_root_sensor).transpose();
    }
    if (order < 2) normal_matrix(2, 2) = 1.0;  // the unused acceleration row: a = 0
    const Eigen::Matrix<double, 3, 6> theta = normal_matrix.ldlt().solve(normal_rhs);
    const Eigen::Vector3d at = basis(static_cast<double>(t_ns - last.t_ns) * kSecondsPerNs, order);
    return last.T_root_sensor * se3_exp((at.transpose() * theta).transpose());
}

}  // namespace lidarfuse::core
