#include "core/preprocess/preprocess.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "core/common/kdtree.hpp"

namespace lidarfuse::core {

void extract_indices(const PointCloud& in, const std::vector<std::uint32_t>& indices,
                     PointCloud* out) {
    const bool normals = in.has_normals();
    const bool covariances = in.has_covariances();
    out->clear();
    out->points.reserve(indices.size());
    if (normals) out->normals.reserve(indices.size());
    if (covariances) out->covariances.reserve(indices.size());
    for (const std::uint32_t i : indices) {
        out->points.push_back(in.points[i]);
        if (normals) out->normals.push_back(in.normals[i]);
        if (covariances) out->covariances.push_back(in.covariances[i]);
    }
}

namespace {

// Applies a keep mask: fills `kept` (the caller's buffer or a local one) and the output.
std::size_t apply_mask(const PointCloud& in, const std::vector<char>& keep, PointCloud* out,
                       std::vector<std::uint32_t>* kept_indices) {
    std::vector<std::uint32_t> local;
    std::vector<std::uint32_t>& kept = kept_indices ? *kept_indices : local;
    kept.clear();
    for (std::size_t i = 0; i < keep.size(); ++i) {
        if (keep[i]) kept.push_back(static_cast<std::uint32_t>(i));
    }
    extract_indices(in, kept, out);
    return kept.size();
}

}  // namespace

std::size_t filter_range(const PointCloud& in, const RangeFilterParams& params, PointCloud* out,
                         std::vector<std::uint32_t>* kept_indices) {
    const double min2 = params.min_range_m * params.min_range_m;
    const double max2 = params.max_range_m * params.max_range_m;
    const bool normals = in.has_normals();
    const bool covariances = in.has_covariances();
    out->clear();
    if (kept_indices) kept_indices->clear();
    for (std::size_t i = 0; i < in.points.size(); ++i) {
        const Eigen::Vector3d& p = in.points[i];
        if (!p.allFinite()) continue;
        const double r2 = (p - params.origin).squaredNorm();
        if (r2 < min2 || r2 > max2) continue;
        out->points.push_back(p);
        if (normals) out->normals.push_back(in.normals[i]);
        if (covariances) out->covariances.push_back(in.covariances[i]);
        if (kept_indices) kept_indices->push_back(static_cast<std::uint32_t>(i));
    }
    return out->points.size();
}

std::size_t remove_statistical_outliers(const PointCloud& in,
                                        const StatisticalOutlierParams& params, PointCloud* out,
                                        std::vector<std::uint32_t>* kept_indices, int num_threads) {
    const std::size_t n = in.points.size();
    const std::size_t k = static_cast<std::size_t>(std::max(1, params.k_neighbors));
    if (n <= k) {
        // Too few points for a neighborhood statistic: keep everything.
        std::vector<char> keep(n, 1);
        return apply_mask(in, keep, out, kept_indices);
    }
    const KdTree tree(in.points, 10, num_threads);
    std::vector<double> mean_distance(n, 0.0);
    const long long count = static_cast<long long>(n);
#pragma omp parallel num_threads(std::max(1, num_threads)) if (num_threads > 1)
    {
        // k + 1: the query point is its own nearest neighbor.
        std::vector<std::uint32_t> idx(k + 1);
        std::vector<double> d2(k + 1);
#pragma omp for schedule(static)
        for (long long i = 0; i < count; ++i) {
            const std::size_t found = tree.knn(in.points[i], k + 1, idx.data(), d2.data());
            double sum = 0.0;
            for (std::size_t j = 1; j < found; ++j) sum += std::sqrt(d2[j]);
            mean_distance[i] = found > 1 ? sum / static_cast<double>(found - 1) : 0.0;
        }
    }
    double mean = 0.0;
    for (const double d : mean_distance) mean += d;
    mean /= static_cast<double>(n);
    double var = 0.0;
    for (const double d : mean_distance) var += (d - mean) * (d - mean);
    const double stddev = std::sqrt(var / static_cast<double>(n - 1));
    const double threshold = mean + params.std_ratio * stddev;
    std::vector<char> keep(n);
    for (std::size_t i = 0; i < n; ++i) keep[i] = mean_distance[i] <= threshold ? 1 : 0;
    return apply_mask(in, keep, out, kept_indices);
}

std::size_t remove_radius_outliers(const PointCloud& in, const RadiusOutlierParams& params,
                                   PointCloud* out, std::vector<std::uint32_t>* kept_indices,
                                   int num_threads) {
    const std::size_t n = in.points.size();
    std::vector<char> keep(n, 0);
    if (n > 0) {
        const KdTree tree(in.points, 10, num_threads);
        // The query point itself is among its neighbors, hence + 1.
        const std::size_t needed = static_cast<std::size_t>(std::max(0, params.min_neighbors)) + 1;
        const double r2 = params.radius_m * params.radius_m;
        const long long count = static_cast<long long>(n);
#pragma omp parallel num_threads(std::max(1, num_threads)) if (num_threads > 1)
        {
            // A knn query of `needed` points is cheaper than a full radius search: the point
            // stays if its needed-th nearest neighbor lies within the radius.
            std::vector<std::uint32_t> idx(needed);
            std::vector<double> d2(needed);
#pragma omp for schedule(static)
            for (long long i = 0; i < count; ++i) {
                const std::size_t found = tree.knn(in.points[i], needed, idx.data(), d2.data());
                keep[i] = (found == needed && d2[needed - 1] <= r2) ? 1 : 0;
            }
        }
    }
    return apply_mask(in, keep, out, kept_indices);
}

}  // namespace lidarfuse::core
