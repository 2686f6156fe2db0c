#pragma once
// Change detection between two scans of one sensor in spherical coordinates (Underwood,
// Gillsjo, Bailey, Vlaskine 2013, "Explicit 3D change detection using ray-tracing in
// spherical coordinates"), as PAPER.md's dynamic-object removal uses it.
//
// Both scans are expressed in the same frame: the reference scan's sensor frame (the
// caller pre-aligns the current scan with its pose estimate). A point is a change when the
// other scan saw THROUGH it: every measurement of the other scan inside a small cone around
// the point's ray lies farther than the point by more than range_threshold_m. So
//   added[i]   (current point i): empty space in the reference -> something arrived
//   removed[j] (reference point j): empty space now -> something left
// Cones without any measurement of the other scan give no evidence (no flag): a sky or
// out-of-range ray is never taken as proof of empty space.
//
// The cone is a window of +-cone_bins cells in an azimuth x elevation grid; the minimum
// range over the window is precomputed once per scan (separable min filter), so each point
// costs O(1). Grid and buffers are reused between calls. What is rebuilt for every scan (the
// current scan's image, its points' cells and ranges) lives in a ChangeDetectionScratch,
// which the detectors of several sensors share when they run one after another on one thread.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace lidarfuse::core {

struct SphericalGridParams {
    int azimuth_bins = 1024;           // 0.35 deg at 1024: one OS1 column
    int elevation_bins = 192;          // over the span below
    double min_elevation_deg = -60.0;  // rays outside the span are not examined
    double max_elevation_deg = 60.0;
};

// The azimuth x elevation cells of a sensor frame.
class SphericalGrid {
public:
    explicit SphericalGrid(const SphericalGridParams& params = {});
    // Cell of a point; false when outside the elevation span, at the origin or not finite.
    bool cell_of(const Eigen::Vector3d& p, int* az, int* el, double* range_m) const;
    int index(int az, int el) const { return el * params_.azimuth_bins + az; }
    std::size_t cells() const;
    const SphericalGridParams& params() const { return params_; }

private:
    SphericalGridParams params_;
    double az_scale_, el_scale_, el_min_rad_;
    // Cell boundaries, so that cell_of() needs neither asin nor atan2 per point (it is run on
    // every point of every scan): sin of each row's lower elevation (elevation_bins + 1),
    // each column's lower azimuth as a unit vector, and per slot of z/r in [-1, 1] the row
    // of the slot's lower end (-1 below the span), which is at most one row off.
    std::vector<double> sin_el_lower_;
    std::vector<double> cos_az_lower_, sin_az_lower_;
    std::vector<std::int16_t> row_of_slot_;
};

// A rows x cols image of ranges, +infinity (no measurement) until written, whose rows are
// filled, and their memory touched, only from their first use on: a sensor covers a band
// of the grid's elevations (an OS1-64 45 of 120 degrees), and the rows outside it never
// become resident memory (bench/BENCHMARK.md, "8 sensors on 2 cores").
class BandedImage {
public:
    BandedImage(int rows, int cols);
    // Row r, to read or write; set to +infinity on first use, with the rows between it and
    // the rows used so far.
    double* row(int r);
    // The value of a cell (row-major index); +infinity in a row never used.
    double at(std::size_t cell) const {
        return cell >= band_begin_ && cell < band_end_ ? data_[cell] : kNone;
    }
    // Becomes a copy of `other` (same size): its band of rows is copied, nothing else touched.
    void assign(const BandedImage& other);

private:
    static constexpr double kNone = std::numeric_limits<double>::infinity();
    void fill(int first_row, int last_row);

    int cols_;
    std::unique_ptr<double[]> data_;  // allocated untouched; rows [lo_, hi_] filled
    int lo_ = 0, hi_ = -1;
    std::size_t band_begin_ = 0, band_end_ = 0;  // cells of rows [lo_, hi_]
};

// Per cell: the nearest range of the points whose rays fall in it (metres), +inf if none.
class SphericalRangeImage {
public:
    explicit SphericalRangeImage(const SphericalGridParams& params = {});
    void build(const std::vector<Eigen::Vector3d>& points_in_sensor_frame);
    // The same, also keeping each point's cell index (-1: outside the grid) and range, so
    // that callers classify the points without a second asin/atan2 per point.
    void build(const std::vector<Eigen::Vector3d>& points_in_sensor_frame,
               std::vector<std::int32_t>* cells, std::vector<double>* ranges_m);
    bool cell_of(const Eigen::Vector3d& p, int* az, int* el, double* range_m) const {
        return grid_.cell_of(p, az, el, range_m);
    }
    // Minimum range over the (2 * cone_bins + 1)^2 window around each cell, wrapping in
    // azimuth; call after build(), before window_min().
    void compute_window_min(int cone_bins);
    double window_min(int az, int el) const {
        return window_min_.at(static_cast<std::size_t>(grid_.index(az, el)));
    }
    double window_min_at(std::int32_t cell) const {
        return window_min_.at(static_cast<std::size_t>(cell));
    }
    double nearest(int az, int el) const {
        return nearest_.at(static_cast<std::size_t>(grid_.index(az, el)));
    }
    const SphericalGrid& grid() const { return grid_; }
    // The image compute_window_min() wrote (what window_min() reads).
    const BandedImage& window_min_image() const { return window_min_; }

private:
    void clear_rows(BandedImage* image, int lo, int hi) const;

    SphericalGrid grid_;
    BandedImage nearest_;
    BandedImage scratch_;
    BandedImage window_min_;
    std::vector<double> row_;  // one padded azimuth row (compute_window_min)
    // Rows that hold finite values (lo > hi: none). A sensor covers a band of elevations
    // (an OS1-64 45 of the 120 degrees), so the window and the clearing skip the others.
    int nearest_lo_, nearest_hi_, window_lo_, window_hi_;
};

// What ChangeDetector rebuilds for every scan: the scan's range image (3 images of the grid,
// about 1.8 MB resident for an OS1-64's band) and its points' cells and ranges (12 bytes per
// point). One per thread serves every sensor prepared on it: per sensor it would be about
// 2.5 MB each, held between frames for nothing.
struct ChangeDetectionScratch {
    explicit ChangeDetectionScratch(const SphericalGridParams& grid = {}) : image(grid) {}
    SphericalRangeImage image;
    std::vector<std::int32_t> cells;
    std::vector<double> ranges_m;
};

struct ChangeDetectionParams {
    SphericalGridParams grid;
    int cone_bins = 1;               // cone half-width in cells (about 0.35-0.6 deg)
    double range_threshold_m = 0.5;  // "significant" range change, well above noise
};

struct ChangeDetectionResult {
    std::vector<std::uint8_t> added;    // per current point
    std::vector<std::uint8_t> removed;  // per reference point
    std::size_t num_added = 0;
    std::size_t num_removed = 0;
};

// Keeps the reference scan's window minimum, cells and ranges between calls; one object per
// sensor (not thread safe). The scan being compared is imaged in a scratch: the caller's
// (shared by the detectors that run on one thread), or without one the detector's own.
class ChangeDetector {
public:
    explicit ChangeDetector(const ChangeDetectionParams& params = {});
    const ChangeDetectionParams& params() const { return params_; }

    // Sets the reference scan (points in its sensor frame); built once, reused per frame.
    void set_reference(const std::vector<Eigen::Vector3d>& reference_points);
    void set_reference(const std::vector<Eigen::Vector3d>& reference_points,
                       ChangeDetectionScratch* scratch);
    bool has_reference() const { return has_reference_; }

    // `current_in_reference_frame`: the current scan mapped into the reference sensor frame.
    void detect(const std::vector<Eigen::Vector3d>& current_in_reference_frame,
                ChangeDetectionResult* result);
    void detect(const std::vector<Eigen::Vector3d>& current_in_reference_frame,
                ChangeDetectionResult* result, ChangeDetectionScratch* scratch);

private:
    // The detector's own scratch, made on first use; `scratch` made fit for this grid.
    ChangeDetectionScratch* own_scratch();
    void fit(ChangeDetectionScratch* scratch) const;

    ChangeDetectionParams params_;
    BandedImage reference_window_min_;
    std::size_t num_reference_ = 0;
    // Per reference point: cell (-1: outside the grid) and range, computed once.
    std::vector<std::int32_t> reference_cells_;
    std::vector<double> reference_ranges_;
    bool has_reference_ = false;
    std::unique_ptr<ChangeDetectionScratch> own_scratch_;
};

}  // namespace lidarfuse::core
