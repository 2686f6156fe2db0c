#include "core/change_detection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lidarfuse::core {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

SphericalGrid::SphericalGrid(const SphericalGridParams& params) : params_(params) {
    params_.azimuth_bins = std::max(params_.azimuth_bins, 8);
    params_.elevation_bins = std::max(params_.elevation_bins, 2);
    if (!(params_.max_elevation_deg > params_.min_elevation_deg)) {
        params_.min_elevation_deg = -60.0;
        params_.max_elevation_deg = 60.0;
    }
    az_scale_ = params_.azimuth_bins / (2.0 * kPi);
    el_min_rad_ = params_.min_elevation_deg * kPi / 180.0;
    el_scale_ = params_.elevation_bins /
                ((params_.max_elevation_deg - params_.min_elevation_deg) * kPi / 180.0);
}

std::size_t SphericalGrid::cells() const {
    return static_cast<std::size_t>(params_.azimuth_bins) *
           static_cast<std::size_t>(params_.elevation_bins);
}

SphericalRangeImage::SphericalRangeImage(const SphericalGridParams& params)
    : grid_(params),
      nearest_(grid_.cells(), kInf),
      scratch_(grid_.cells(), kInf),
      window_min_(grid_.cells(), kInf) {}

bool SphericalGrid::cell_of(const Eigen::Vector3d& p, int* az, int* el, double* range_m) const {
    const double r = p.norm();
    if (!(r > 1e-6) || !std::isfinite(r)) return false;
    const double elevation = std::asin(std::clamp(p.z() / r, -1.0, 1.0));
    const int e = static_cast<int>(std::floor((elevation - el_min_rad_) * el_scale_));
    if (e < 0 || e >= params_.elevation_bins) return false;
    double azimuth = std::atan2(p.y(), p.x());
    if (azimuth < 0) azimuth += 2.0 * kPi;
    int a = static_cast<int>(azimuth * az_scale_);
    if (a >= params_.azimuth_bins) a = params_.azimuth_bins - 1;
    *az = a;
    *el = e;
    *range_m = r;
    return true;
}

void SphericalRangeImage::build(const std::vector<Eigen::Vector3d>& points) {
    std::fill(nearest_.begin(), nearest_.end(), kInf);
    int az = 0, el = 0;
    double r = 0;
    for (const auto& p : points) {
        if (!cell_of(p, &az, &el, &r)) continue;
        double& cell = nearest_[grid_.index(az, el)];
        cell = std::min(cell, r);
    }
}

void SphericalRangeImage::compute_window_min(int cone_bins) {
    const int W = grid_.params().azimuth_bins, H = grid_.params().elevation_bins;
    const auto index = [this](int a, int e) { return grid_.index(a, e); };
    // Separable min filter: azimuth (wrapping) into scratch_, then elevation (clamped).
    for (int e = 0; e < H; ++e) {
        for (int a = 0; a < W; ++a) {
            double m = kInf;
            for (int d = -cone_bins; d <= cone_bins; ++d) m = std::min(m, nearest_[index((a + d + W) % W, e)]);
            scratch_[index(a, e)] = m;
        }
    }
    for (int e = 0; e < H; ++e) {
        const int lo = std::max(0, e - cone_bins), hi = std::min(H - 1, e + cone_bins);
        for (int a = 0; a < W; ++a) {
            double m = kInf;
            for (int k = lo; k <= hi; ++k) m = std::min(m, scratch_[index(a, k)]);
            window_min_[index(a, e)] = m;
        }
    }
}

ChangeDetector::ChangeDetector(const ChangeDetectionParams& params)
    : params_(params), reference_image_(params.grid), current_image_(params.grid) {}

void ChangeDetector::set_reference(const std::vector<Eigen::Vector3d>& reference_points) {
    reference_points_ = reference_points;
    reference_image_.build(reference_points_);
    reference_image_.compute_window_min(params_.cone_bins);
    has_reference_ = true;
}

void ChangeDetector::detect(const std::vector<Eigen::Vector3d>& current, ChangeDetectionResult* result) {
    result->added.assign(current.size(), 0);
    result->removed.assign(reference_points_.size(), 0);
    result->num_added = result->num_removed = 0;
    if (!has_reference_) return;
    current_image_.build(current);
    current_image_.compute_window_min(params_.cone_bins);
    const double threshold = params_.range_threshold_m;
    int az = 0, el = 0;
    double r = 0;
    // The other scan saw through the point when even its nearest measurement in the cone
    // lies beyond the point (+inf: no measurement, no evidence).
    for (std::size_t i = 0; i < current.size(); ++i) {
        if (!current_image_.cell_of(current[i], &az, &el, &r)) continue;
        const double other = reference_image_.window_min(az, el);
        if (std::isfinite(other) && other > r + threshold) {
            result->added[i] = 1;
            ++result->num_added;
        }
    }
    for (std::size_t j = 0; j < reference_points_.size(); ++j) {
        if (!reference_image_.cell_of(reference_points_[j], &az, &el, &r)) continue;
        const double other = current_image_.window_min(az, el);
        if (std::isfinite(other) && other > r + threshold) {
            result->removed[j] = 1;
            ++result->num_removed;
        }
    }
}

}  // namespace lidarfuse::core
