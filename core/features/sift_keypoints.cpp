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

// sigma_k = base_m * 2^(k / scales_per_octave) (m), k = 0 .. n_scales - 1.
std::vector<double> octave_sigmas(double base_m, int n_scales, int scales_per_octave) {
    std::vector<double> sigma(n_scales);
    for (int k = 0; k < n_scales; ++k) {
        sigma[k] = base_m * std::pow(2.0, static_cast<double>(k) / scales_per_octave);
    }
    return sigma;
}

// Gaussian scale space of one octave's curvature, L[i * n_scales + k], and each point's
// extremum neighborhood (the other points within extremum_m).
struct ScaleSpace {
    std::vector<double> smoothed;
    std::vector<std::vector<std::uint32_t>> near;
};

ScaleSpace smooth_curvature(const OctaveCloud& cloud, const KdTree& tree,
                            const std::vector<double>& sigma, double extremum_m, int threads) {
    const auto n = static_cast<std::int64_t>(cloud.points.size());
    const int n_scales = static_cast<int>(sigma.size());
    const double search_m = kTruncationSigmas * sigma.back();
    ScaleSpace space;
    space.smoothed.resize(static_cast<std::size_t>(n) * n_scales);
    space.near.resize(static_cast<std::size_t>(n));
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
                    space.near[i].push_back(j);
                }
            }
            for (int k = 0; k < n_scales; ++k) {
                space.smoothed[i * n_scales + k] = value_sum[k] / weight_sum[k];
            }
        }
    }
    return space;
}

// Difference of Gaussians, D[i * n_dog + k] = L_{k+1} - L_k, n_dog = n_scales - 1.
std::vector<double> difference_of_gaussians(const std::vector<double>& smoothed, std::int64_t n,
                                            int n_scales) {
    const int n_dog = n_scales - 1;
    std::vector<double> dog(static_cast<std::size_t>(n) * n_dog);
    for (std::int64_t i = 0; i < n; ++i) {
        for (int k = 0; k < n_dog; ++k) {
            dog[i * n_dog + k] = smoothed[i * n_scales + k + 1] - smoothed[i * n_scales + k];
        }
    }
    return dog;
}

// True when D_k of point i is a strict extremum among its neighbors at k - 1, k and k + 1.
bool is_extremum(const std::vector<double>& dog, int n_dog, std::int64_t i, int k,
                 const std::vector<std::uint32_t>& near) {
    const double v = dog[i * n_dog + k];
    bool is_max = v > dog[i * n_dog + k - 1] && v > dog[i * n_dog + k + 1];
    bool is_min = v < dog[i * n_dog + k - 1] && v < dog[i * n_dog + k + 1];
    for (std::uint32_t j : near) {
        if (!is_max && !is_min) break;
        for (int dk = -1; dk <= 1; ++dk) {
            const double u = dog[j * n_dog + k + dk];
            is_max = is_max && v > u;
            is_min = is_min && v < u;
        }
    }
    return is_max || is_min;
}

// Per point, the first DoG level at which it is an extremum over space and the adjacent
// scales with at least min_contrast; -1: none.
std::vector<int> find_extrema(const std::vector<double>& dog, int n_dog,
                              const std::vector<std::vector<std::uint32_t>>& near,
                              double min_contrast, int threads) {
    const auto n = static_cast<std::int64_t>(near.size());
    std::vector<int> found_at(static_cast<std::size_t>(n), -1);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
    for (std::int64_t i = 0; i < n; ++i) {
        for (int k = 1; k + 1 < n_dog; ++k) {
            const double v = dog[i * n_dog + k];
            if (std::abs(v) < min_contrast || near[i].empty()) continue;
            if (is_extremum(dog, n_dog, i, k, near[i])) {
                found_at[i] = k;
                break;
            }
        }
    }
    return found_at;
}

// Moves each extremum to its nearest input point and keeps that point's smallest scale.
void record_keypoints(const OctaveCloud& cloud, const std::vector<int>& found_at,
                      const std::vector<double>& sigma, const KdTree& input_tree,
                      std::vector<float>* best_scale) {
    for (std::size_t i = 0; i < found_at.size(); ++i) {
        if (found_at[i] < 0) continue;
        std::uint32_t nearest = 0;
        double d2 = 0.0;
        if (!input_tree.nearest(cloud.points[i], &nearest, &d2)) continue;
        const auto scale = static_cast<float>(sigma[found_at[i]]);
        if ((*best_scale)[nearest] == 0.0f || scale < (*best_scale)[nearest])
            (*best_scale)[nearest] = scale;
    }
}

// One octave at base scale base_m (m): its keypoints into best_scale. False when its cloud
// is too small, which ends the pyramid.
bool detect_in_octave(const std::vector<Eigen::Vector3d>& points,
                      const std::vector<double>& curvature, const SiftKeypointParams& params,
                      double base_m, const KdTree& input_tree, int threads,
                      std::vector<float>* best_scale) {
    const int n_scales = params.scales_per_octave + 3;  // Gaussian levels per octave
    const OctaveCloud cloud = voxel_average(points, curvature, base_m);
    const auto n = static_cast<std::int64_t>(cloud.points.size());
    if (n < params.min_points_per_octave) return false;
    const KdTree tree(cloud.points);
    const std::vector<double> sigma = octave_sigmas(base_m, n_scales, params.scales_per_octave);
    const ScaleSpace space =
        smooth_curvature(cloud, tree, sigma, kExtremumRadiusVoxels * base_m, threads);
    const std::vector<double> dog = difference_of_gaussians(space.smoothed, n, n_scales);
    const std::vector<int> found_at =
        find_extrema(dog, n_scales - 1, space.near, params.min_contrast, threads);
    record_keypoints(cloud, found_at, sigma, input_tree, best_scale);
    return true;
}

}  // namespace

SiftKeypointResult detect_sift_keypoints(const std::vector<Eigen::Vector3d>& points,
                                         const std::vector<double>& curvature,
                                         const SiftKeypointParams& params, int num_threads) {
    SiftKeypointResult result;
    if (points.empty() || curvature.size() != points.size() || !(params.min_scale_m > 0.0) ||
        params.octaves < 1 || params.scales_per_octave < 1) {
        return result;
    }
    const KdTree input_tree(points);
    std::vector<float> best_scale(points.size(), 0.0f);  // 0: not a keypoint
    for (int octave = 0; octave < params.octaves; ++octave) {
        const double base_m = params.min_scale_m * std::pow(2.0, octave);
        if (!detect_in_octave(points, curvature, params, base_m, input_tree,
                              std::max(1, num_threads), &best_scale)) {
            break;
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
