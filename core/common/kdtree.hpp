#pragma once
// A 3-D k-d tree over a vector of points, for the small clouds of registration (a few
// thousand voxel centroids, searched a hundred thousand times a frame) as for whole scans.
// It keeps its own copy of the points in leaf order, so that a leaf's points are
// contiguous in memory and a search reads them without an index indirection; splits at the
// middle of a node's widest extent. Searches are exact. Results name the caller's indices.
// Queries are const and safe to call from several threads at once.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace lidarfuse::core {

class KdTree {
public:
    // `num_threads` > 1 builds the upper levels' subtrees in parallel (large clouds only).
    explicit KdTree(const std::vector<Eigen::Vector3d>& points, int leaf_max_size = 10,
                    int num_threads = 1);
    ~KdTree();
    KdTree(const KdTree&) = delete;
    KdTree& operator=(const KdTree&) = delete;

    std::size_t size() const;
    // The caller's indices in the tree's leaf order: neighbors in space are neighbors
    // here, so queries for every point of the cloud taken in this order share their paths
    // through the tree and its cached points (the same answers, found sooner).
    const std::vector<std::uint32_t>& leaf_order() const;

    // Up to k nearest neighbors of `query`, nearest first. Writes indices and squared
    // distances (m^2) into the caller's arrays (capacity >= k); returns how many.
    std::size_t knn(const Eigen::Vector3d& query, std::size_t k, std::uint32_t* indices,
                    double* squared_distances) const;

    // The nearest neighbor; false when the tree is empty (nearest_within without a bound).
    bool nearest(const Eigen::Vector3d& query, std::uint32_t* index,
                 double* squared_distance) const;

    // The nearest neighbor closer than sqrt(max_squared_distance); false when there is
    // none. Exact, and much faster than nearest() when the bound is tight: subtrees
    // farther than the bound are never visited (G-ICP passes its correspondence bound, or
    // the distance to the previous iteration's neighbor when that is smaller).
    bool nearest_within(const Eigen::Vector3d& query, double max_squared_distance,
                        std::uint32_t* index, double* squared_distance) const;

    // All points within `radius_m` of `query` (index, squared distance), nearest first.
    // `out` is cleared first; reuse it across calls to avoid allocation.
    std::size_t radius(const Eigen::Vector3d& query, double radius_m,
                       std::vector<std::pair<std::uint32_t, double>>* out) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace lidarfuse::core
