#pragma once
// The point cloud every core algorithm works on: positions plus optional per-point
// attributes that stages fill once and later stages reuse (normals, covariances).
// Frame: whatever the producer says (a sensor frame for a scan, the root frame for the
// fused cloud). Units: metres.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace lidarfuse::core {

struct PointCloud {
    std::vector<Eigen::Vector3d> points;
    // Unit surface normals, same size as points when computed (else empty).
    std::vector<Eigen::Vector3d> normals;
    // 3x3 position covariances (G-ICP), same size as points when computed (else empty).
    std::vector<Eigen::Matrix3d> covariances;
    // Each point's kNeighborListSize nearest other points of this cloud (indices, nearest
    // first; n * kNeighborListSize entries, padded with the point's own index where the
    // cloud has fewer points) and the squared distance (m^2) within which every other point
    // is listed (infinity when all are). Empty when not computed. The covariances' k-NN
    // pass fills both for free (normals.hpp); G-ICP uses them to find a correspondence
    // without a k-d tree search (gicp.hpp). Filters do not copy them: a merged or
    // re-sampled cloud has other neighbors.
    static constexpr std::size_t kNeighborListSize = 8;
    std::vector<std::uint32_t> neighbor_list;
    std::vector<double> neighbor_reach_d2;
    // When the covariances are G-ICP plane covariances (normals.hpp), their axes: unit
    // vectors with covariances[i] = I - (1 - covariance_epsilon) a a^T (a zero axis for the
    // identity of a degenerate point). G-ICP inverts pairs of them in closed form. Empty
    // otherwise; filters do not copy them (G-ICP then uses the matrices alone).
    std::vector<Eigen::Vector3d> covariance_axes;
    double covariance_epsilon = 0.0;

    std::size_t size() const { return points.size(); }
    bool empty() const { return points.empty(); }
    bool has_normals() const { return !points.empty() && normals.size() == points.size(); }
    bool has_covariances() const { return !points.empty() && covariances.size() == points.size(); }
    bool has_neighbor_lists() const {
        return !points.empty() && neighbor_reach_d2.size() == points.size() &&
               neighbor_list.size() == points.size() * kNeighborListSize;
    }
    bool has_plane_covariances() const {
        return has_covariances() && covariance_axes.size() == points.size() &&
               covariance_epsilon > 0.0 && covariance_epsilon < 1.0;
    }
    void clear() {
        points.clear();
        normals.clear();
        covariances.clear();
        neighbor_list.clear();
        neighbor_reach_d2.clear();
        covariance_axes.clear();
        covariance_epsilon = 0.0;
    }
};

}  // namespace lidarfuse::core
