#include "core/dynamics/change_detection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/angles.hpp"

namespace lidarfuse::core {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kElevationSlots = 4096;
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
    const int W = params_.azimuth_bins, H = params_.elevation_bins;
    for (int k = 0; k <= H; ++k) {
        const double lower = el_min_rad_ + k / el_scale_;
        sin_el_lower_.push_back(std::sin(std::clamp(lower, -kPi / 2, kPi / 2)));
    }
    for (int k = 0; k < W; ++k) {
        cos_az_lower_.push_back(std::cos(k / az_scale_));
        sin_az_lower_.push_back(std::sin(k / az_scale_));
    }
    row_of_slot_.resize(kElevationSlots);
    int row = -1;
    for (int i = 0; i < kElevationSlots; ++i) {
        const double s = -1.0 + 2.0 * i / kElevationSlots;
        while (row < H && s >= sin_el_lower_[static_cast<std::size_t>(row + 1)]) ++row;
        row_of_slot_[static_cast<std::size_t>(i)] = static_cast<std::int16_t>(row);
    }
}

std::size_t SphericalGrid::cells() const {
    return static_cast<std::size_t>(params_.azimuth_bins) *
           static_cast<std::size_t>(params_.elevation_bins);
}

BandedImage::BandedImage(int rows, int cols)
    : cols_(cols),
      data_(new double[static_cast<std::size_t>(std::max(rows, 0)) *
                       static_cast<std::size_t>(std::max(cols, 0))]) {}

double* BandedImage::row(int r) {
    if (lo_ > hi_) {
        fill(r, r);
        lo_ = hi_ = r;
    } else if (r < lo_) {
        fill(r, lo_ - 1);
        lo_ = r;
    } else if (r > hi_) {
        fill(hi_ + 1, r);
        hi_ = r;
    }
    band_begin_ = static_cast<std::size_t>(lo_) * static_cast<std::size_t>(cols_);
    band_end_ = static_cast<std::size_t>(hi_ + 1) * static_cast<std::size_t>(cols_);
    return &data_[static_cast<std::size_t>(r) * static_cast<std::size_t>(cols_)];
}

void BandedImage::assign(const BandedImage& other) {
    lo_ = other.lo_;
    hi_ = other.hi_;
    band_begin_ = other.band_begin_;
    band_end_ = other.band_end_;
    std::copy(&other.data_[band_begin_], &other.data_[band_end_], &data_[band_begin_]);
}

void BandedImage::fill(int first_row, int last_row) {
    const std::size_t cols = static_cast<std::size_t>(cols_);
    std::fill(&data_[static_cast<std::size_t>(first_row) * cols],
              &data_[static_cast<std::size_t>(last_row + 1) * cols], kInf);
}

SphericalRangeImage::SphericalRangeImage(const SphericalGridParams& params)
    : grid_(params),
      nearest_(params.elevation_bins, params.azimuth_bins),
      scratch_(params.elevation_bins, params.azimuth_bins),
      window_min_(params.elevation_bins, params.azimuth_bins),
      nearest_lo_(grid_.params().elevation_bins),
      nearest_hi_(-1),
      window_lo_(grid_.params().elevation_bins),
      window_hi_(-1) {}

void SphericalRangeImage::clear_rows(BandedImage* image, int lo, int hi) const {
    const int W = grid_.params().azimuth_bins;
    for (int e = lo; e <= hi; ++e) {
        double* row = image->row(e);
        std::fill(row, row + W, kInf);
    }
}

// Row: the last boundary at or below z/r, found from the slot's row (boundaries are at
// least 0.0055 apart in z/r for rows of <= 0.6 deg up to 60 deg, slots 0.0005, so this
// steps at most once). Column: an approximate azimuth (Abramowitz-Stegun 4.4.49, error
// 1e-5 rad against columns of 6e-3 rad at 1024), then the exact side of the column's
// boundaries by cross products. Same cells as asin/atan2 up to rounding at a boundary.
bool SphericalGrid::cell_of(const Eigen::Vector3d& p, int* az, int* el, double* range_m) const {
    const double r = p.norm();
    if (!(r > 1e-6) || !std::isfinite(r)) return false;
    const double s = std::clamp(p.z() / r, -1.0, 1.0);
    const int H = params_.elevation_bins, W = params_.azimuth_bins;
    const int slot =
        std::min(static_cast<int>((s + 1.0) * (kElevationSlots / 2)), kElevationSlots - 1);
    int e = row_of_slot_[static_cast<std::size_t>(slot)];
    while (e < H && s >= sin_el_lower_[static_cast<std::size_t>(e + 1)]) ++e;
    if (e < 0 || e >= H) return false;

    const double x = p.x(), y = p.y();
    const double ax = std::abs(x), ay = std::abs(y);
    int a = 0;
    if (ax == 0 && ay == 0) {  // on the pole: atan2's answer for the signed zeros
        double azimuth = std::atan2(y, x);
        if (azimuth < 0) azimuth += 2.0 * kPi;
        a = std::min(static_cast<int>(azimuth * az_scale_), W - 1);
    } else {
        const double t = std::min(ax, ay) / std::max(ax, ay);
        const double t2 = t * t;
        double angle =
            t *
            (0.9998660 + t2 * (-0.3302995 + t2 * (0.1801410 + t2 * (-0.0851330 + t2 * 0.0208351))));
        if (ay > ax) angle = kPi / 2 - angle;
        if (x < 0) angle = kPi - angle;
        if (y < 0) angle = 2.0 * kPi - angle;
        a = static_cast<int>(angle * az_scale_);
        a = a < 0 ? 0 : a >= W ? W - 1 : a;
        // At or counter-clockwise of column k's lower boundary (within half a turn).
        const auto past = [&](int k) {
            return cos_az_lower_[static_cast<std::size_t>(k)] * y -
                       sin_az_lower_[static_cast<std::size_t>(k)] * x >=
                   0.0;
        };
        for (int step = 0; step < 2 && !past(a); ++step) a = a == 0 ? W - 1 : a - 1;
        for (int step = 0; step < 2 && past(a + 1 == W ? 0 : a + 1); ++step)
            a = a + 1 == W ? 0 : a + 1;
    }
    *az = a;
    *el = e;
    *range_m = r;
    return true;
}

void SphericalRangeImage::build(const std::vector<Eigen::Vector3d>& points) {
    clear_rows(&nearest_, nearest_lo_, nearest_hi_);
    nearest_lo_ = grid_.params().elevation_bins;
    nearest_hi_ = -1;
    int az = 0, el = 0;
    double r = 0;
    for (const auto& p : points) {
        if (!cell_of(p, &az, &el, &r)) continue;
        double& cell = nearest_.row(el)[az];
        cell = std::min(cell, r);
        nearest_lo_ = std::min(nearest_lo_, el);
        nearest_hi_ = std::max(nearest_hi_, el);
    }
}

void SphericalRangeImage::build(const std::vector<Eigen::Vector3d>& points,
                                std::vector<std::int32_t>* cells, std::vector<double>* ranges_m) {
    clear_rows(&nearest_, nearest_lo_, nearest_hi_);
    nearest_lo_ = grid_.params().elevation_bins;
    nearest_hi_ = -1;
    cells->resize(points.size());
    ranges_m->resize(points.size());
    int az = 0, el = 0;
    double r = 0;
    // Consecutive points of a scan row mostly fall in one grid row: its pointer is kept.
    int row_el = -1;
    double* row = nullptr;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (!cell_of(points[i], &az, &el, &r)) {
            (*cells)[i] = -1;
            continue;
        }
        const int index = grid_.index(az, el);
        (*cells)[i] = index;
        (*ranges_m)[i] = r;
        if (el != row_el) {
            row = nearest_.row(el);
            row_el = el;
            nearest_lo_ = std::min(nearest_lo_, el);
            nearest_hi_ = std::max(nearest_hi_, el);
        }
        row[az] = std::min(row[az], r);
    }
}

void SphericalRangeImage::compute_window_min(int cone_bins) {
    const int W = grid_.params().azimuth_bins, H = grid_.params().elevation_bins;
    const int c = std::clamp(cone_bins, 0, W / 2);
    // Separable min filter: azimuth (wrapping) into scratch_, then elevation (clamped).
    // A row padded with c wrapped cells on each side keeps the inner loop free of modulos.
    std::vector<double>& row = row_;
    row.resize(static_cast<std::size_t>(W + 2 * c));
    clear_rows(&window_min_, window_lo_, window_hi_);
    if (nearest_lo_ > nearest_hi_) {
        window_lo_ = H;
        window_hi_ = -1;
        return;
    }
    for (int e = nearest_lo_; e <= nearest_hi_; ++e) {
        const double* in = nearest_.row(e);
        for (int k = 0; k < c; ++k) {
            row[static_cast<std::size_t>(k)] = in[W - c + k];
            row[static_cast<std::size_t>(W + c + k)] = in[k];
        }
        std::copy(in, in + W, row.begin() + c);
        double* out = scratch_.row(e);
        for (int a = 0; a < W; ++a) {
            double m = kInf;
            for (int d = 0; d <= 2 * c; ++d) m = std::min(m, row[static_cast<std::size_t>(a + d)]);
            out[a] = m;
        }
    }
    window_lo_ = std::max(0, nearest_lo_ - c);
    window_hi_ = std::min(H - 1, nearest_hi_ + c);
    for (int e = window_lo_; e <= window_hi_; ++e) {
        const int lo = std::max(nearest_lo_, e - c), hi = std::min(nearest_hi_, e + c);
        double* out = window_min_.row(e);
        for (int k = lo; k <= hi; ++k) {
            const double* in = scratch_.row(k);
            for (int a = 0; a < W; ++a) out[a] = std::min(out[a], in[a]);
        }
    }
}

ChangeDetector::ChangeDetector(const ChangeDetectionParams& params)
    : params_(params),
      reference_window_min_(params.grid.elevation_bins, params.grid.azimuth_bins) {}

ChangeDetectionScratch* ChangeDetector::own_scratch() {
    if (!own_scratch_) own_scratch_ = std::make_unique<ChangeDetectionScratch>(params_.grid);
    return own_scratch_.get();
}

void ChangeDetector::fit(ChangeDetectionScratch* scratch) const {
    const SphericalGridParams& have = scratch->image.grid().params();
    const SphericalGridParams& want = params_.grid;
    if (have.azimuth_bins != want.azimuth_bins || have.elevation_bins != want.elevation_bins ||
        have.min_elevation_deg != want.min_elevation_deg ||
        have.max_elevation_deg != want.max_elevation_deg) {
        scratch->image = SphericalRangeImage(want);
    }
}

void ChangeDetector::set_reference(const std::vector<Eigen::Vector3d>& reference_points) {
    set_reference(reference_points, own_scratch());
}

void ChangeDetector::set_reference(const std::vector<Eigen::Vector3d>& reference_points,
                                   ChangeDetectionScratch* scratch) {
    fit(scratch);
    num_reference_ = reference_points.size();
    scratch->image.build(reference_points, &reference_cells_, &reference_ranges_);
    scratch->image.compute_window_min(params_.cone_bins);
    reference_window_min_.assign(scratch->image.window_min_image());
    has_reference_ = true;
}

void ChangeDetector::detect(const std::vector<Eigen::Vector3d>& current,
                            ChangeDetectionResult* result) {
    detect(current, result, own_scratch());
}

void ChangeDetector::detect(const std::vector<Eigen::Vector3d>& current,
                            ChangeDetectionResult* result, ChangeDetectionScratch* scratch) {
    result->added.assign(current.size(), 0);
    result->removed.assign(num_reference_, 0);
    result->num_added = result->num_removed = 0;
    if (!has_reference_) return;
    fit(scratch);
    SphericalRangeImage& image = scratch->image;
    const std::vector<std::int32_t>& cells = scratch->cells;
    const std::vector<double>& ranges = scratch->ranges_m;
    image.build(current, &scratch->cells, &scratch->ranges_m);
    image.compute_window_min(params_.cone_bins);
    const double threshold = params_.range_threshold_m;
    // The other scan saw through the point when even its nearest measurement in the cone
    // lies beyond the point (+inf: no measurement, no evidence).
    for (std::size_t i = 0; i < current.size(); ++i) {
        if (cells[i] < 0) continue;
        const double other = reference_window_min_.at(static_cast<std::size_t>(cells[i]));
        if (std::isfinite(other) && other > ranges[i] + threshold) {
            result->added[i] = 1;
            ++result->num_added;
        }
    }
    for (std::size_t j = 0; j < num_reference_; ++j) {
        if (reference_cells_[j] < 0) continue;
        const double other = image.window_min_at(reference_cells_[j]);
        if (std::isfinite(other) && other > reference_ranges_[j] + threshold) {
            result->removed[j] = 1;
            ++result->num_removed;
        }
    }
}

}  // namespace lidarfuse::core
