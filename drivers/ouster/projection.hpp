#pragma once
// LidarScan -> point cloud in the Ouster sensor frame (metres), through the per-pixel
// xyz lookup table of xyz_lut.hpp (p = offset + range_m * direction).
//
// One point per pixel with a return (range > 0) in a column that arrived; pixels are
// visited in staggered row-major order (row * W + measurement_id), so the output order is
// deterministic. Optionally each point keeps its pixel index, from which its row, column
// and acquisition time (the column timestamp) follow, for deskewing.
//
// project_scan() reuses the capacity of `out`: after the first frame of a sensor it does
// not allocate. Thread safety: pure functions; the LUT is read-only.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/point_cloud.hpp"
#include "drivers/ouster/lidar_scan.hpp"
#include "drivers/ouster/xyz_lut.hpp"

namespace lidarfuse::ouster {

struct ProjectionParams {
    bool second_return = false;      // project range2 (dual profiles) instead of range
    std::uint32_t min_range_mm = 1;  // returns closer than this are dropped (0 = no return)
    bool keep_pixel_index = true;    // fill ScanCloud::pixel_index
};

struct ScanCloud {
    core::PointCloud cloud;      // sensor frame, metres; empty when projected as float points
    std::size_t num_points = 0;  // points projected (in `cloud` or the caller's float points)
    // Staggered pixel index (row * columns + measurement_id) of every point, when kept.
    std::vector<std::uint32_t> pixel_index;
    // Copy of the scan's per-column timestamps (ns, sensor clock), indexed by
    // measurement_id: point i was measured at column_timestamp_ns[pixel_index[i] % columns].
    std::vector<std::uint64_t> column_timestamp_ns;
    std::uint32_t frame_id = 0;
    std::size_t rows = 0;
    std::size_t columns = 0;

    std::size_t row_of(std::size_t point) const { return pixel_index[point] / columns; }
    std::size_t column_of(std::size_t point) const { return pixel_index[point] % columns; }
    std::uint64_t timestamp_ns_of(std::size_t point) const {
        return column_timestamp_ns[column_of(point)];
    }
};

// The instant a scan's pose refers to: column 0's timestamp, or the first column that
// arrived when column 0 did not (azimuth window, loss). Sensor clock, ns; 0 if none arrived.
std::uint64_t scan_reference_time_ns(const LidarScan& scan);

// Each point's acquisition time relative to `reference_ns`, in seconds (for deskewing).
// Needs the pixel indices (ProjectionParams::keep_pixel_index); zeros otherwise.
void point_times_s(const ScanCloud& cloud, std::uint64_t reference_ns, std::vector<float>* out);

// Each point's intensity for consumers of the fused cloud (PointCloud2 `intensity`): the
// first return's signal (photon counts) where the profile carries it, else its
// reflectivity, else 0. Needs the pixel indices; zeros otherwise.
void point_intensity(const LidarScan& scan, const ScanCloud& cloud, std::vector<float>* out);

// Projects `scan` into `out` (previous contents replaced). The LUT must have the scan's
// H x W; a mismatch, or a second return the scan lacks, yields an empty cloud and false.
bool project_scan(const LidarScan& scan, const XyzLut& lut, const ProjectionParams& params,
                  ScanCloud* out);

// The same projection with the points in single precision into `points` (the fusion's scan
// input, core::SensorScanInput::points), computed in double and rounded once; `out` gets
// everything else (pixel indices, column times), its cloud left empty.
bool project_scan(const LidarScan& scan, const XyzLut& lut, const ProjectionParams& params,
                  ScanCloud* out, std::vector<Eigen::Vector3f>* points);

}  // namespace lidarfuse::ouster
