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
    // Squared distance (m^2) from each point to the nearest other point of this cloud,
    // same size as points when computed (else empty). The covariances' k-NN pass fills it
    // for free (normals.hpp); G-ICP uses it to certify a correspondence without a search
    // (gicp.hpp). Filters do not copy it: a merged or re-sampled cloud has other gaps.
    std::vector<double> nearest_other_d2;

    std::size_t size() const { return points.size(); }
    bool empty() const { return points.empty(); }
    bool has_normals() const { return !points.empty() && normals.size() == points.size(); }
    bool has_covariances() const {
        return !points.empty() && covariances.size() == points.size();
    }
    bool has_nearest_other_d2() const {
        return !points.empty() && nearest_other_d2.size() == points.size();
    }
    void clear() {
        points.clear();
        normals.clear();
        covariances.clear();
        nearest_other_d2.clear();
    }
};

}  // namespace lidarfuse::core
