#include "core/registration/free_space_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lidarfuse::core {

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

}  // namespace

FreeSpaceMap::FreeSpaceMap(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Vector3d>& normals,
                           const FreeSpaceParams& params)
    : params_(params) {
    params_.azimuth_bin_deg = std::max(params.azimuth_bin_deg, 1e-3);
    params_.elevation_bin_deg = std::max(params.elevation_bin_deg, 1e-3);
    num_azimuth_ = static_cast<int>(std::ceil(360.0 / params_.azimuth_bin_deg));
    num_elevation_ = static_cast<int>(std::ceil(180.0 / params_.elevation_bin_deg));
    const auto bins =
        static_cast<std::size_t>(num_azimuth_) * static_cast<std::size_t>(num_elevation_);
    min_range_m_.assign(bins, std::numeric_limits<float>::infinity());
    range_slack_m_.assign(bins, 0.0f);
    const bool with_normals = normals.size() == points.size();
    // The largest angle between a ray and a point of its bin (rad).
    const double bin_rad = std::max(params_.azimuth_bin_deg, params_.elevation_bin_deg) / kRadToDeg;
    const double max_tan = std::tan(std::clamp(params_.max_incidence_deg, 0.0, 89.9) / kRadToDeg);
    for (std::size_t i = 0; i < points.size(); ++i) {
        double range = 0.0;
        const long b = bin(points[i], &range);
        if (b < 0 || !(range < min_range_m_[static_cast<std::size_t>(b)])) continue;
        double tan_incidence = 0.0;
        if (with_normals && normals[i].allFinite()) {
            const double cos_incidence = std::min(1.0, std::abs(normals[i].dot(points[i])) / range);
            tan_incidence = cos_incidence > 0.0
                                ? std::sqrt(1.0 - cos_incidence * cos_incidence) / cos_incidence
                                : std::numeric_limits<double>::infinity();
        }
        min_range_m_[static_cast<std::size_t>(b)] = static_cast<float>(range);
        // Beyond the largest incidence the bin's first surface is not bounded: untested.
        range_slack_m_[static_cast<std::size_t>(b)] =
            tan_incidence > max_tan ? std::numeric_limits<float>::infinity()
                                    : static_cast<float>(range * bin_rad * tan_incidence);
    }
}

long FreeSpaceMap::bin(const Eigen::Vector3d& p, double* range) const {
    *range = p.norm();
    if (!(*range > 1e-9) || !std::isfinite(*range)) return -1;
    const double azimuth_deg = std::atan2(p.y(), p.x()) * kRadToDeg + 180.0;  // [0, 360]
    const double elevation_deg =
        std::asin(std::clamp(p.z() / *range, -1.0, 1.0)) * kRadToDeg + 90.0;
    const int a =
        std::min(num_azimuth_ - 1, static_cast<int>(azimuth_deg / params_.azimuth_bin_deg));
    const int e =
        std::min(num_elevation_ - 1, static_cast<int>(elevation_deg / params_.elevation_bin_deg));
    return static_cast<long>(e) * num_azimuth_ + a;
}

FreeSpaceResult free_space_violations(const std::vector<Eigen::Vector3d>& source_points,
                                      const FreeSpaceMap& target,
                                      const Eigen::Isometry3d& T_target_source) {
    FreeSpaceResult result;
    if (target.empty()) return result;
    const FreeSpaceParams& params = target.params();
    for (const Eigen::Vector3d& p_source : source_points) {
        double range = 0.0;
        const long b = target.bin(T_target_source * p_source, &range);
        if (b < 0 || range < params.min_range_m) continue;
        const double first_return_m = target.first_return_m(b);
        // The target saw nothing there, or only a surface too oblique to bound its range.
        if (!std::isfinite(first_return_m) || !std::isfinite(target.range_slack_m(b))) continue;
        ++result.num_tested;
        const double margin_m =
            params.margin_m + params.margin_share * range + target.range_slack_m(b);
        if (range < first_return_m - margin_m) ++result.num_violations;
    }
    if (result.num_tested > 0) {
        result.violation_share =
            static_cast<double>(result.num_violations) / static_cast<double>(result.num_tested);
    }
    return result;
}

FreeSpaceResult free_space_violations_both(const std::vector<Eigen::Vector3d>& source_points,
                                           const FreeSpaceMap& source,
                                           const std::vector<Eigen::Vector3d>& target_points,
                                           const FreeSpaceMap& target,
                                           const Eigen::Isometry3d& T_target_source) {
    const FreeSpaceResult forward = free_space_violations(source_points, target, T_target_source);
    const FreeSpaceResult backward =
        free_space_violations(target_points, source, T_target_source.inverse());
    return forward.violation_share >= backward.violation_share ? forward : backward;
}

FreeSpaceResult free_space_violations(const std::vector<Eigen::Vector3d>& source_points,
                                      const std::vector<Eigen::Vector3d>& target_points,
                                      const Eigen::Isometry3d& T_target_source,
                                      const FreeSpaceParams& params) {
    return free_space_violations(source_points, FreeSpaceMap(target_points, {}, params),
                                 T_target_source);
}

FreeSpaceResult free_space_violations_both(const std::vector<Eigen::Vector3d>& source_points,
                                           const std::vector<Eigen::Vector3d>& target_points,
                                           const Eigen::Isometry3d& T_target_source,
                                           const FreeSpaceParams& params) {
    return free_space_violations_both(source_points, FreeSpaceMap(source_points, {}, params),
                                      target_points, FreeSpaceMap(target_points, {}, params),
                                      T_target_source);
}

}  // namespace lidarfuse::core
