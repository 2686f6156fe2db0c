#include "core/features/sift_keypoints.hpp"

#include <algorithm>
#include <cmath>

#include "core/common/kdtree.hpp"

namespace lidarfuse::core {

namespace {

// The Gaussian is truncated at this many sigma (weight e^-3.1 = 4 % at the edge).
constexpr double kTruncationSigmas = 2.5;
// Extremum neighborhood radius in units of the octave's voxel size (about the 26
// neighboring voxels).
constexpr double kExtremumRadiusVoxels = 1.75;

struct OctaveCloud {
    std::vector<Eigen::Vector3d> points;
    std::vector<double> curvature;
};

// Voxel-grid average of points and curvature; deterministic (sorted by voxel key).
OctaveCloud voxel_average(const std::vector<Eigen::Vector3d>& points,
                          const std::vector<double>& curvature, double voxel_m) {
    struct Entry {
        std::int64_t x, y, z;
        std::uint32_t index;
    };
    std::vector<Entry> entries;
    entries.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (!points[i].allFinite() || !std::isfinite(curvature[i])) continue;
        const Eigen::Vector3d c = (points[i] / voxel_m).array().floor();
        entries.push_back({static_cast<std::int64_t>(c.x()), static_cast<std::int64_t>(c.y()),
                           static_cast<std::int64_t>(c.z()), static_cast<std::uint32_t>(i)});
    }
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
        if (a.x != b.x) return a.x < b.x;
        if (a.y != b.y) return a.y < b.y;
        if (a.z != b.z) return a.z < b.z;
        return a.index < b.index;
    });
    OctaveCloud out;
    std::size_t begin = 0;
    while (begin < entries.size()) {
        std::size_t end = begin;
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        double curvature_sum = 0.0;
        while (end < entries.size() && entries[end].x == entries[begin].x &&
               entries[end].y == entries[begin].y && entries[end].z == entries[begin].z) {
            sum += points[entries[end].index];
            curvature_sum += curvature[entries[end].index];
            ++end;
        }
        const double n = static_cast<double>(end - begin);
        out.points.push_back(sum / n);
        out.curvature.push_back(curvature_sum / n);
        begin = end;
    }
    return out;
}

}  // namespace

SiftKeypointResult detect_sift_keypoints(const std::vector<Eigen::Vector3d>& points,
                                         const std::vector<double>& curvature,
                                         const SiftKeypointParams& params) {
    SiftKeypointResult result;
    if (points.empty() || curvature.size() != points.size() || !(params.min_scale_m > 0.0) ||
        params.octaves < 1 || params.scales_per_octave < 1) {
        return result;
    }
    const int threads = std::max(1, params.num_threads);
    const int n_scales = params.scales_per_octave + 3;  // Gaussian levels per octave
    const KdTree input_tree(points);
    std::vector<float> best_scale(points.size(), 0.0f);  // 0: not a keypoint

    for (int octave = 0; octave < params.octaves; ++octave) {
        const double base_m = params.min_scale_m * std::pow(2.0, octave);
        const OctaveCloud cloud = voxel_average(points, curvature, base_m);
        const auto n = static_cast<std::int64_t>(cloud.points.size());
        if (n < params.min_points_per_octave) break;
        const KdTree tree(cloud.points);

        std::vector<double> sigma(n_scales);
        for (int k = 0; k < n_scales; ++k) {
            sigma[k] = base_m * std::pow(2.0, static_cast<double>(k) / params.scales_per_octave);
        }
        const double search_m = kTruncationSigmas * sigma.back();
        const double extremum_m = kExtremumRadiusVoxels * base_m;

        // Gaussian scale space of curvature, L[i * n_scales + k], and each point's
        // extremum neighborhood.
        std::vector<double> smoothed(static_cast<std::size_t>(n) * n_scales);
        std::vector<std::vector<std::uint32_t>> near(static_cast<std::size_t>(n));
#pragma omp parallel num_threads(threads)
        {
            std::vector<std::pair<std::uint32_t, double>> neighbors;
            std::vector<double> weight_sum(n_scales);
            std::vector<double> value_sum(n_scales);
#pragma omp for schedule(dynamic, 64)
            for (std::int64_t i = 0; i < n; ++i) {
                tree.radius(cloud.points[i], search_m, &neighbors);
                std::fill(weight_sum.begin(), weight_sum.end(), 0.0);
                std::fill(value_sum.begin(), value_sum.end(), 0.0);
                for (const auto& [j, d2] : neighbors) {
                    for (int k = 0; k < n_scales; ++k) {
                        const double reach = kTruncationSigmas * sigma[k];
                        if (d2 > reach * reach) continue;
                        const double w = std::exp(-0.5 * d2 / (sigma[k] * sigma[k]));
                        weight_sum[k] += w;
                        value_sum[k] += w * cloud.curvature[j];
                    }
                    if (j != static_cast<std::uint32_t>(i) && d2 <= extremum_m * extremum_m) {
                        near[i].push_back(j);
                    }
                }
                for (int k = 0; k < n_scales; ++k) {
                    smoothed[i * n_scales + k] = value_sum[k] / weight_sum[k];
                }
            }
        }

        // Difference of Gaussians, D[i * n_dog + k] = L_{k+1} - L_k.
        const int n_dog = n_scales - 1;
        std::vector<double> dog(static_cast<std::size_t>(n) * n_dog);
        for (std::int64_t i = 0; i < n; ++i) {
            for (int k = 0; k < n_dog; ++k) {
                dog[i * n_dog + k] = smoothed[i * n_scales + k + 1] - smoothed[i * n_scales + k];
            }
        }

        // Extrema over space and the adjacent scales.
        std::vector<int> found_at(static_cast<std::size_t>(n), -1);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
        for (std::int64_t i = 0; i < n; ++i) {
            for (int k = 1; k + 1 < n_dog; ++k) {
                const double v = dog[i * n_dog + k];
                if (std::abs(v) < params.min_contrast || near[i].empty()) continue;
                bool is_max = v > dog[i * n_dog + k - 1] && v > dog[i * n_dog + k + 1];
                bool is_min = v < dog[i * n_dog + k - 1] && v < dog[i * n_dog + k + 1];
                for (std::uint32_t j : near[i]) {
                    if (!is_max && !is_min) break;
                    for (int dk = -1; dk <= 1; ++dk) {
                        const double u = dog[j * n_dog + k + dk];
                        is_max = is_max && v > u;
                        is_min = is_min && v < u;
                    }
                }
                if (is_max || is_min) {
                    found_at[i] = k;
                    break;
                }
            }
        }

        for (std::int64_t i = 0; i < n; ++i) {
            if (found_at[i] < 0) continue;
            std::uint32_t nearest = 0;
            double d2 = 0.0;
            if (!input_tree.nearest(cloud.points[i], &nearest, &d2)) continue;
            const auto scale = static_cast<float>(sigma[found_at[i]]);
            if (best_scale[nearest] == 0.0f || scale < best_scale[nearest])
                best_scale[nearest] = scale;
        }
    }

    for (std::size_t i = 0; i < points.size(); ++i) {
        if (best_scale[i] > 0.0f) {
            result.indices.push_back(static_cast<std::uint32_t>(i));
            result.scale_m.push_back(best_scale[i]);
        }
    }
    return result;
}

}  // namespace lidarfuse::core
