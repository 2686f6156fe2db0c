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

void SphericalRangeImage::build(const std::vector<Eigen::Vector3d>& points,
                                std::vector<std::int32_t>* cells, std::vector<double>* ranges_m) {
    std::fill(nearest_.begin(), nearest_.end(), kInf);
    cells->resize(points.size());
    ranges_m->resize(points.size());
    int az = 0, el = 0;
    double r = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (!cell_of(points[i], &az, &el, &r)) {
            (*cells)[i] = -1;
            continue;
        }
        const int index = grid_.index(az, el);
        (*cells)[i] = index;
        (*ranges_m)[i] = r;
        double& cell = nearest_[static_cast<std::size_t>(index)];
        cell = std::min(cell, r);
    }
}

void SphericalRangeImage::compute_window_min(int cone_bins) {
    const int W = grid_.params().azimuth_bins, H = grid_.params().elevation_bins;
    const int c = std::clamp(cone_bins, 0, W / 2);
    // Separable min filter: azimuth (wrapping) into scratch_, then elevation (clamped).
    // A row padded with c wrapped cells on each side keeps the inner loop free of modulos.
    std::vector<double>& row = row_;
    row.resize(static_cast<std::size_t>(W + 2 * c));
    for (int e = 0; e < H; ++e) {
        const double* in = &nearest_[static_cast<std::size_t>(grid_.index(0, e))];
        for (int k = 0; k < c; ++k) {
            row[static_cast<std::size_t>(k)] = in[W - c + k];
            row[static_cast<std::size_t>(W + c + k)] = in[k];
        }
        std::copy(in, in + W, row.begin() + c);
        double* out = &scratch_[static_cast<std::size_t>(grid_.index(0, e))];
        for (int a = 0; a < W; ++a) {
            double m = kInf;
            for (int d = 0; d <= 2 * c; ++d) m = std::min(m, row[static_cast<std::size_t>(a + d)]);
            out[a] = m;
        }
    }
    std::fill(window_min_.begin(), window_min_.end(), kInf);
    for (int e = 0; e < H; ++e) {
        const int lo = std::max(0, e - cone_bins), hi = std::min(H - 1, e + cone_bins);
        double* out = &window_min_[static_cast<std::size_t>(grid_.index(0, e))];
        for (int k = lo; k <= hi; ++k) {
            const double* in = &scratch_[static_cast<std::size_t>(grid_.index(0, k))];
            for (int a = 0; a < W; ++a) out[a] = std::min(out[a], in[a]);
        }
    }
}

ChangeDetector::ChangeDetector(const ChangeDetectionParams& params)
    : params_(params), reference_image_(params.grid), current_image_(params.grid) {}

void ChangeDetector::set_reference(const std::vector<Eigen::Vector3d>& reference_points) {
    num_reference_ = reference_points.size();
    reference_image_.build(reference_points, &reference_cells_, &reference_ranges_);
    reference_image_.compute_window_min(params_.cone_bins);
    has_reference_ = true;
}

void ChangeDetector::detect(const std::vector<Eigen::Vector3d>& current, ChangeDetectionResult* result) {
    result->added.assign(current.size(), 0);
    result->removed.assign(num_reference_, 0);
    result->num_added = result->num_removed = 0;
    if (!has_reference_) return;
    current_image_.build(current, &current_cells_, &current_ranges_);
    current_image_.compute_window_min(params_.cone_bins);
    const double threshold = params_.range_threshold_m;
    // The other scan saw through the point when even its nearest measurement in the cone
    // lies beyond the point (+inf: no measurement, no evidence).
    for (std::size_t i = 0; i < current.size(); ++i) {
        if (current_cells_[i] < 0) continue;
        const double other = reference_image_.window_min_at(current_cells_[i]);
        if (std::isfinite(other) && other > current_ranges_[i] + threshold) {
            result->added[i] = 1;
            ++result->num_added;
        }
    }
    for (std::size_t j = 0; j < num_reference_; ++j) {
        if (reference_cells_[j] < 0) continue;
        const double other = current_image_.window_min_at(reference_cells_[j]);
        if (std::isfinite(other) && other > reference_ranges_[j] + threshold) {
            result->removed[j] = 1;
            ++result->num_removed;
        }
    }
}

}  // namespace lidarfuse::core
