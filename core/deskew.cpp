#include "core/deskew.hpp"

namespace lidarfuse::core {

Vector6d body_twist_per_s(const Eigen::Isometry3d& T_world_a, const Eigen::Isometry3d& T_world_b,
                          double dt_s) {
    if (!(dt_s > 0)) return Vector6d::Zero();
    return se3_log(T_world_a.inverse() * T_world_b) / dt_s;
}

void deskew_points(const Vector6d& twist_per_s, const std::vector<float>& point_dt_s,
                   std::vector<Eigen::Vector3d>* points) {
    if (twist_per_s.isZero(0.0) || point_dt_s.size() != points->size()) return;
    float cached_dt = 0.0f;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    bool have = false;
    for (std::size_t i = 0; i < points->size(); ++i) {
        const float dt = point_dt_s[i];
        if (!have || dt != cached_dt) {
            T = se3_exp(twist_per_s * static_cast<double>(dt));
            cached_dt = dt;
            have = true;
        }
        (*points)[i] = T * (*points)[i];
    }
}

}  // namespace lidarfuse::core
