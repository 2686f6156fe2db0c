#pragma once
// The point cloud every core algorithm works on: positions plus optional per-point
// attributes that stages fill once and later stages reuse (normals, covariances).
// Frame: whatever the producer says (a sensor frame for a scan, the root frame for the
// fused cloud). Units: metres. What only G-ICP needs besides the covariances (the k-d tree,
// the neighbor lists, the plane axes) is kept beside the cloud, in GicpCloud
// (registration/gicp_cloud.hpp).

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace lidarfuse::core {

struct PointCloud {
    std::vector<Eigen::Vector3d> points;
    // Unit surface normals, same size as points when computed (else empty).
    std::vector<Eigen::Vector3d> normals;
    // 3x3 position covariances (G-ICP), same size as points when computed (else empty).
    std::vector<Eigen::Matrix3d> covariances;

    std::size_t size() const { return points.size(); }
    bool empty() const { return points.empty(); }
    bool has_normals() const { return !points.empty() && normals.size() == points.size(); }
    bool has_covariances() const { return !points.empty() && covariances.size() == points.size(); }
    void clear() {
        points.clear();
        normals.clear();
        covariances.clear();
    }
};

// `in`'s points in `out`'s precision (a projected cloud into a scan's single-precision
// points, a scan's points into a cloud the core computes on); out's capacity is reused.
template <typename To, typename From>
void cast_points(const std::vector<From>& in, std::vector<To>* out) {
    out->resize(in.size());
    for (std::size_t i = 0; i < in.size(); ++i)
        (*out)[i] = in[i].template cast<typename To::Scalar>();
}

}  // namespace lidarfuse::core
