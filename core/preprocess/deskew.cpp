#include "core/preprocess/deskew.hpp"

#include <algorithm>
#include <cmath>

namespace lidarfuse::core {

namespace {
// Below this rotation over the sweep the series form is used (see deskew_points).
constexpr double kSeriesMaxAngleRad = 0.01;
}  // namespace

Vector6d body_twist_per_s(const Eigen::Isometry3d& T_world_a, const Eigen::Isometry3d& T_world_b,
                          double dt_s) {
    if (!(dt_s > 0)) return Vector6d::Zero();
    return se3_log(T_world_a.inverse() * T_world_b) / dt_s;
}

void deskew_points(const Vector6d& twist_per_s, const std::vector<float>& point_dt_s,
                   std::vector<Eigen::Vector3d>* points) {
    if (twist_per_s.isZero(0.0) || point_dt_s.size() != points->size() || points->empty()) return;
    const Eigen::Vector3d omega = twist_per_s.head<3>();
    const Eigen::Vector3d v = twist_per_s.tail<3>();
    const auto [lo, hi] = std::minmax_element(point_dt_s.begin(), point_dt_s.end());
    const double max_dt_s =
        std::max(std::abs(static_cast<double>(*lo)), std::abs(static_cast<double>(*hi)));
    if (omega.norm() * max_dt_s <= kSeriesMaxAngleRad) {
        // exp(xi dt) to second order in theta = omega dt (error < theta^3 / 6 < 2e-7 rad):
        //   R p = p + theta x p + theta x (theta x p) / 2
        //   t   = (I + [theta]x / 2 + [theta]x^2 / 6) v dt
        // Cheaper than Rodrigues per point: consecutive points of a scan are often of
        // different columns (row-major pixel order), so a per-column cache would miss.
        for (std::size_t i = 0; i < points->size(); ++i) {
            const double dt = static_cast<double>(point_dt_s[i]);
            const Eigen::Vector3d theta = omega * dt;
            const Eigen::Vector3d vdt = v * dt;
            const Eigen::Vector3d tv = theta.cross(vdt);
            Eigen::Vector3d& p = (*points)[i];
            const Eigen::Vector3d a = theta.cross(p);
            p += a + 0.5 * theta.cross(a) + vdt + 0.5 * tv + theta.cross(tv) / 6.0;
        }
        return;
    }
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
