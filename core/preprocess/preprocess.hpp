#pragma once
// Pre-processing (PAPER.md, initial registration step 2; continuous registration): drop
// invalid points, crop by range, remove outliers.
//
// Every filter copies the kept points into `out` (together with normals / covariances when
// the input has them) and optionally writes, per kept point, its index in the input
// (`kept_indices`), so callers can carry labels along. `out` may not alias `in`. Buffers
// are reused: pass the same `out` every frame to avoid reallocation.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/point_cloud.hpp"

namespace lidarfuse::core {

struct RangeFilterParams {
    // Range is measured from `origin` (the sensor origin in the cloud's frame).
    double min_range_m = 0.5;  // drops no-return pixels (range 0) and the sensor housing
    double max_range_m = 200.0;
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();
};

// Keeps finite points with min_range_m <= |p - origin| <= max_range_m. Returns the count.
std::size_t filter_range(const PointCloud& in, const RangeFilterParams& params, PointCloud* out,
                         std::vector<std::uint32_t>* kept_indices = nullptr);

struct StatisticalOutlierParams {
    // Each point's mean distance to its k nearest neighbors is compared with the
    // distribution over the whole cloud; points beyond mean + std_ratio * stddev go.
    int k_neighbors = 16;
    double std_ratio = 2.0;
};

// Input points must be finite (run filter_range first). Returns the count kept.
std::size_t remove_statistical_outliers(const PointCloud& in,
                                        const StatisticalOutlierParams& params, PointCloud* out,
                                        std::vector<std::uint32_t>* kept_indices = nullptr,
                                        int num_threads = 1);

struct RadiusOutlierParams {
    // A point stays if at least min_neighbors other points lie within radius_m.
    double radius_m = 0.5;
    int min_neighbors = 3;
};

std::size_t remove_radius_outliers(const PointCloud& in, const RadiusOutlierParams& params,
                                   PointCloud* out,
                                   std::vector<std::uint32_t>* kept_indices = nullptr,
                                   int num_threads = 1);

// Copies the selected points (and normals / covariances when present) into `out`.
void extract_indices(const PointCloud& in, const std::vector<std::uint32_t>& indices,
                     PointCloud* out);

}  // namespace lidarfuse::core
