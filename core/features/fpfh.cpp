#include "core/features/fpfh.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/common/kdtree.hpp"

namespace lidarfuse::core {

namespace {

using Neighbors = std::vector<std::pair<std::uint32_t, double>>;

int bin_of(double value, double lo, double hi) {
    const int bin = static_cast<int>(std::floor((value - lo) / (hi - lo) * kFpfhBinsPerAngle));
    return std::clamp(bin, 0, kFpfhBinsPerAngle - 1);
}

// Scales each 11-bin block to sum 100 (blocks that are all zero stay zero).
void normalise_blocks(FpfhDescriptor* h) {
    for (int block = 0; block < 3; ++block) {
        auto segment = h->segment<kFpfhBinsPerAngle>(block * kFpfhBinsPerAngle);
        const float sum = segment.sum();
        if (sum > 0.0f) segment *= 100.0f / sum;
    }
}

// Simplified point feature histogram of point `i` against `neighbors` (its radius set).
FpfhDescriptor spfh(const PointCloud& cloud, std::uint32_t i, const Neighbors& neighbors) {
    FpfhDescriptor h = FpfhDescriptor::Zero();
    for (const auto& [j, d2] : neighbors) {
        if (j == i) continue;
        double alpha = 0.0;
        double phi = 0.0;
        double theta = 0.0;
        if (!pair_features(cloud.points[i], cloud.normals[i], cloud.points[j], cloud.normals[j],
                           &alpha, &phi, &theta)) {
            continue;
        }
        h[bin_of(alpha, -1.0, 1.0)] += 1.0f;
        h[kFpfhBinsPerAngle + bin_of(phi, -1.0, 1.0)] += 1.0f;
        h[2 * kFpfhBinsPerAngle + bin_of(theta, -M_PI, M_PI)] += 1.0f;
    }
    normalise_blocks(&h);
    return h;
}

// Radius neighborhoods of the keypoints.
std::vector<Neighbors> keypoint_neighborhoods(const PointCloud& cloud, const KdTree& tree,
                                              const std::vector<std::uint32_t>& keypoints,
                                              double radius_m, int threads) {
    const auto n_keypoints = static_cast<std::int64_t>(keypoints.size());
    std::vector<Neighbors> neighborhoods(keypoints.size());
#pragma omp parallel for num_threads(threads) schedule(dynamic, 16)
    for (std::int64_t k = 0; k < n_keypoints; ++k) {
        tree.radius(cloud.points[keypoints[k]], radius_m, &neighborhoods[k]);
    }
    return neighborhoods;
}

// The points whose SPFH is needed, in order of first use, and each cloud point's slot among
// them (-1: not needed).
struct SpfhSlots {
    std::vector<std::uint32_t> needed;
    std::vector<std::int32_t> slot;
};

void require(std::uint32_t i, SpfhSlots* slots) {
    if (slots->slot[i] < 0) {
        slots->slot[i] = static_cast<std::int32_t>(slots->needed.size());
        slots->needed.push_back(i);
    }
}

// Every point whose SPFH is needed: the keypoints and their neighbors.
SpfhSlots needed_points(std::size_t cloud_size, const std::vector<std::uint32_t>& keypoints,
                        const std::vector<Neighbors>& keypoint_neighbors) {
    SpfhSlots slots;
    slots.slot.assign(cloud_size, -1);
    for (std::size_t k = 0; k < keypoints.size(); ++k) {
        require(keypoints[k], &slots);
        for (const auto& neighbor : keypoint_neighbors[k]) require(neighbor.first, &slots);
    }
    return slots;
}

// SPFH of every needed point, in the order of `needed`.
std::vector<FpfhDescriptor> needed_spfhs(const PointCloud& cloud, const KdTree& tree,
                                         const std::vector<std::uint32_t>& needed, double radius_m,
                                         int threads) {
    std::vector<FpfhDescriptor> spfhs(needed.size());
    const auto n_needed = static_cast<std::int64_t>(needed.size());
#pragma omp parallel num_threads(threads)
    {
        Neighbors neighbors;
#pragma omp for schedule(dynamic, 32)
        for (std::int64_t s = 0; s < n_needed; ++s) {
            tree.radius(cloud.points[needed[s]], radius_m, &neighbors);
            spfhs[s] = spfh(cloud, needed[s], neighbors);
        }
    }
    return spfhs;
}

// FPFH of keypoint k: its own SPFH plus the 1/distance-weighted mean of its neighbors' SPFHs.
FpfhDescriptor combine(std::uint32_t keypoint, const Neighbors& neighbors,
                       const std::vector<FpfhDescriptor>& spfhs, const SpfhSlots& slots) {
    FpfhDescriptor weighted = FpfhDescriptor::Zero();
    double weight_sum = 0.0;
    for (const auto& [j, d2] : neighbors) {
        if (j == keypoint || !(d2 > 0.0)) continue;
        const double weight = 1.0 / std::sqrt(d2);
        weighted += static_cast<float>(weight) * spfhs[slots.slot[j]];
        weight_sum += weight;
    }
    FpfhDescriptor out = spfhs[slots.slot[keypoint]];
    if (weight_sum > 0.0) {
        out = 0.5f * (out + weighted / static_cast<float>(weight_sum));
    }
    // Keep each block at sum 100 even when the point's own SPFH is empty.
    normalise_blocks(&out);
    return out;
}

}  // namespace

bool pair_features(const Eigen::Vector3d& p1, const Eigen::Vector3d& n1, const Eigen::Vector3d& p2,
                   const Eigen::Vector3d& n2, double* alpha, double* phi, double* theta) {
    Eigen::Vector3d d = p2 - p1;
    const double length = d.norm();
    if (!(length > 1e-12)) return false;
    d /= length;
    // Source: the point whose normal is closer to the connecting line (Rusu's rule), so the
    // features do not depend on the order of the pair.
    const bool swap = std::abs(n1.dot(d)) < std::abs(n2.dot(d));
    const Eigen::Vector3d& ns = swap ? n2 : n1;
    const Eigen::Vector3d& nt = swap ? n1 : n2;
    if (swap) d = -d;
    const Eigen::Vector3d u = ns;
    Eigen::Vector3d v = u.cross(d);
    const double v_norm = v.norm();
    if (v_norm > 1e-9) {
        v /= v_norm;
    } else {
        // d parallel to the normal: any axis perpendicular to u spans the frame.
        v = u.unitOrthogonal();
    }
    const Eigen::Vector3d w = u.cross(v);
    *alpha = v.dot(nt);
    *phi = u.dot(d);
    *theta = std::atan2(w.dot(nt), u.dot(nt));
    return true;
}

std::vector<FpfhDescriptor> compute_fpfh(const PointCloud& cloud,
                                         const std::vector<std::uint32_t>& keypoints,
                                         const FpfhParams& params, int num_threads) {
    std::vector<FpfhDescriptor> descriptors(keypoints.size(), FpfhDescriptor::Zero());
    if (!cloud.has_normals() || keypoints.empty() || !(params.radius_m > 0.0)) return descriptors;
    for (std::uint32_t k : keypoints) {
        if (k >= cloud.size()) return descriptors;
    }
    const KdTree tree(cloud.points);
    const int threads = std::max(1, num_threads);
    const std::vector<Neighbors> keypoint_neighbors =
        keypoint_neighborhoods(cloud, tree, keypoints, params.radius_m, threads);
    const SpfhSlots slots = needed_points(cloud.size(), keypoints, keypoint_neighbors);
    const std::vector<FpfhDescriptor> spfhs =
        needed_spfhs(cloud, tree, slots.needed, params.radius_m, threads);
    const auto n_keypoints = static_cast<std::int64_t>(keypoints.size());
#pragma omp parallel for num_threads(threads) schedule(static)
    for (std::int64_t k = 0; k < n_keypoints; ++k) {
        descriptors[k] = combine(keypoints[k], keypoint_neighbors[k], spfhs, slots);
    }
    return descriptors;
}

}  // namespace lidarfuse::core
