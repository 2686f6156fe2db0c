#include "core/free_space_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lidarfuse::core {

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// Smallest range per (azimuth, elevation) bin over the full sphere.
class RayGrid {
public:
    explicit RayGrid(const FreeSpaceParams& params)
        : azimuth_bin_deg_(std::max(params.azimuth_bin_deg, 1e-3)),
          elevation_bin_deg_(std::max(params.elevation_bin_deg, 1e-3)),
          num_azimuth_(static_cast<int>(std::ceil(360.0 / azimuth_bin_deg_))),
          num_elevation_(static_cast<int>(std::ceil(180.0 / elevation_bin_deg_))),
          min_range_(static_cast<std::size_t>(num_azimuth_) * static_cast<std::size_t>(num_elevation_),
                     std::numeric_limits<double>::infinity()) {}

    // -1 for a point at the origin or not finite.
    long bin(const Eigen::Vector3d& p, double* range) const {
        *range = p.norm();
        if (!(*range > 1e-9) || !std::isfinite(*range)) return -1;
        const double azimuth_deg = std::atan2(p.y(), p.x()) * kRadToDeg + 180.0;  // [0, 360]
        const double elevation_deg = std::asin(std::clamp(p.z() / *range, -1.0, 1.0)) * kRadToDeg + 90.0;
        const int a = std::min(num_azimuth_ - 1, static_cast<int>(azimuth_deg / azimuth_bin_deg_));
        const int e = std::min(num_elevation_ - 1, static_cast<int>(elevation_deg / elevation_bin_deg_));
        return static_cast<long>(e) * num_azimuth_ + a;
    }

    void insert(const Eigen::Vector3d& p) {
        double range = 0.0;
        const long b = bin(p, &range);
        if (b >= 0) min_range_[static_cast<std::size_t>(b)] = std::min(min_range_[static_cast<std::size_t>(b)], range);
    }

    double min_range(long b) const { return min_range_[static_cast<std::size_t>(b)]; }

private:
    double azimuth_bin_deg_;
    double elevation_bin_deg_;
    int num_azimuth_;
    int num_elevation_;
    std::vector<double> min_range_;
};

}  // namespace

FreeSpaceResult free_space_violations(const std::vector<Eigen::Vector3d>& source_points,
                                      const std::vector<Eigen::Vector3d>& target_points,
                                      const Eigen::Isometry3d& T_target_source,
                                      const FreeSpaceParams& params) {
    RayGrid grid(params);
    for (const Eigen::Vector3d& p : target_points) grid.insert(p);

    FreeSpaceResult result;
    for (const Eigen::Vector3d& p_source : source_points) {
        double range = 0.0;
        const long b = grid.bin(T_target_source * p_source, &range);
        if (b < 0 || range < params.min_range_m) continue;
        const double first_return_m = grid.min_range(b);
        if (!std::isfinite(first_return_m)) continue;  // the target saw nothing there
        ++result.num_tested;
        if (range < first_return_m - (params.margin_m + params.margin_share * range)) ++result.num_violations;
    }
    if (result.num_tested > 0) {
        result.violation_share =
            static_cast<double>(result.num_violations) / static_cast<double>(result.num_tested);
    }
    return result;
}

FreeSpaceResult free_space_violations_both(const std::vector<Eigen::Vector3d>& source_points,
                                           const std::vector<Eigen::Vector3d>& target_points,
                                           const Eigen::Isometry3d& T_target_source,
                                           const FreeSpaceParams& params) {
    const FreeSpaceResult forward = free_space_violations(source_points, target_points, T_target_source, params);
    const FreeSpaceResult backward =
        free_space_violations(target_points, source_points, T_target_source.inverse(), params);
    return forward.violation_share >= backward.violation_share ? forward : backward;
}

}  // namespace lidarfuse::core
