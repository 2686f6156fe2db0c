#pragma once
// Normal-adaptive octree downsampling (PAPER.md step 3, extending Zandara et al. 2013).
// The cloud is cut into cubes of `max_voxel_size_m` (the coarsest voxel, aligned to the
// cloud's bounding box), each the root of an octree. A voxel becomes a leaf when its
// normals agree: the dominant normal direction is voted on a discretised unit sphere (each
// normal votes for its cell and the neighboring cells; normals are folded to one
// hemisphere because their sign is ambiguous), refined as the mean of the agreeing normals,
// and the share of normals within `agreement_angle_deg` of it is compared with
// `min_agreement_share`. Otherwise the voxel is split into its 8 children, down to
// `min_voxel_size_m`. Each leaf is represented by the centroid of its points, their mean
// normal (unit, oriented like the majority of the input normals) and mean curvature.
// Planar regions thus stay coarse and feature-rich regions get fine voxels.
//
// Deterministic; single-threaded (a few ms for a 64k-point scan).

#include <cstdint>
#include <vector>

#include "core/common/point_cloud.hpp"

namespace lidarfuse::core {

struct OctreeDownsampleParams {
    // Coarsest voxel edge (m): no output point represents a larger cube.
    double max_voxel_size_m = 1.0;
    // Finest voxel edge (m): voxels at this size are never split. The actual finest edge is
    // max_voxel_size_m / 2^k for the largest k keeping it >= min_voxel_size_m.
    double min_voxel_size_m = 0.25;
    // A normal agrees with the dominant direction when the angle between their axes is at
    // most this (deg).
    double agreement_angle_deg = 20.0;
    // Split when the share of agreeing normals is below this (0..1).
    double min_agreement_share = 0.9;
    // Voxels with fewer points than this are not split (a normal vote needs a few).
    int min_points_to_split = 8;
    // Leaves with fewer points are dropped (isolated returns).
    int min_points_per_leaf = 1;
    // Angular size of the voting cells on the unit sphere (deg).
    double sphere_cell_deg = 10.0;
};

struct OctreeDownsampleResult {
    // Centroids with unit mean normals (covariances left empty).
    PointCloud cloud;
    // Mean input curvature per output point (empty when none was given).
    std::vector<double> curvature;
    // Edge length of the voxel each output point represents (m), and its point count.
    std::vector<float> voxel_size_m;
    std::vector<std::uint32_t> point_count;
};

// `cloud` must have normals (unit, any sign convention). `curvature` is optional (empty,
// or one value per point). An empty cloud or one without normals gives an empty result.
OctreeDownsampleResult octree_downsample(const PointCloud& cloud,
                                         const std::vector<double>& curvature = {},
                                         const OctreeDownsampleParams& params = {});

// The sphere voting on its own: folds `normals` to a hemisphere, lets each vote for its
// cell and the neighboring cells and returns the refined dominant axis (unit; its sign is
// meaningless) and the share of normals within `agreement_angle_deg` of it.
class NormalVoting {
public:
    NormalVoting(double cell_deg, double agreement_angle_deg);
    struct Vote {
        Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
        double agreeing_share = 0.0;
    };
    // Uses normals[indices[i]] for i in [begin, end). Not thread-safe (scratch buffers).
    Vote dominant(const std::vector<Eigen::Vector3d>& normals, const std::uint32_t* indices,
                  std::size_t count);
    int cell_count() const { return static_cast<int>(centres_.size()); }
    // Cell of a (folded) unit vector.
    int cell_of(const Eigen::Vector3d& unit) const;

private:
    double ring_width_rad_;
    double cos_agreement_;
    std::vector<int> ring_offset_;  // first cell of each polar ring, plus the total
    std::vector<Eigen::Vector3d> centres_;
    std::vector<std::vector<int>> neighbors_;  // per cell, itself included
    std::vector<int> votes_;
};

}  // namespace lidarfuse::core
