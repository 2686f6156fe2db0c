#include "drivers/sim/path.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace lidarfuse::sim {

Path::Path(std::vector<Eigen::Vector2d> points) : points_(std::move(points)) {
    if (points_.size() < 2) throw std::invalid_argument("Path needs at least two points");
    s_.resize(points_.size());
    s_[0] = 0;
    for (std::size_t i = 1; i < points_.size(); ++i) {
        s_[i] = s_[i - 1] + (points_[i] - points_[i - 1]).norm();
    }
}

std::size_t Path::segment(double s) const {
    const auto it = std::upper_bound(s_.begin(), s_.end(), s);
    const auto i = static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - s_.begin() - 1, 0));
    return std::min(i, points_.size() - 2);
}

Eigen::Vector2d Path::position(double s) const {
    const std::size_t i = segment(s);
    const double len = s_[i + 1] - s_[i];
    const double a = len > 0 ? (s - s_[i]) / len : 0.0;
    return points_[i] + a * (points_[i + 1] - points_[i]);
}

Eigen::Vector2d Path::tangent(double s) const {
    const std::size_t i = segment(s);
    return (points_[i + 1] - points_[i]).normalized();
}

double Path::heading(double s) const {
    const Eigen::Vector2d t = tangent(s);
    return std::atan2(t.y(), t.x());
}

Path Path::offset(double lateral_m, double step_m) const {
    std::vector<Eigen::Vector2d> out;
    const int n = std::max(1, static_cast<int>(std::ceil(length() / step_m)));
    for (int k = 0; k <= n; ++k) {
        const double s = length() * k / n;
        // Average the neighboring tangents at vertices so offsets stay smooth on arcs.
        const double eps = std::min(0.25 * step_m, 0.1);
        const Eigen::Vector2d t =
            (tangent(std::max(0.0, s - eps)) + tangent(std::min(length(), s + eps))).normalized();
        out.push_back(position(s) + lateral_m * Eigen::Vector2d(-t.y(), t.x()));
    }
    return Path(std::move(out));
}

Path Path::reversed() const {
    return Path(std::vector<Eigen::Vector2d>(points_.rbegin(), points_.rend()));
}

Path straight_path(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return Path({a, b}); }

std::vector<Eigen::Vector2d> arc_points(const Eigen::Vector2d& centre, double radius_m,
                                        double start_rad, double end_rad, double step_m) {
    const int n =
        std::max(1, static_cast<int>(std::ceil(std::abs(end_rad - start_rad) * radius_m / step_m)));
    std::vector<Eigen::Vector2d> out;
    for (int k = 0; k <= n; ++k) {
        const double a = start_rad + (end_rad - start_rad) * k / n;
        out.push_back(centre + radius_m * Eigen::Vector2d(std::cos(a), std::sin(a)));
    }
    return out;
}

}  // namespace lidarfuse::sim
