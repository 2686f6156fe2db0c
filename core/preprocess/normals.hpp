#pragma once
// Per-point covariances, normals and curvature from the k nearest neighbors, computed once
// per cloud and stored in the PointCloud for every later stage (octree voting, SIFT, FPFH,
// G-ICP).
//
// For point i with neighbors N_i (k nearest, the point itself included):
//   C_i = 1/|N_i| * sum_{j in N_i} (p_j - mean)(p_j - mean)^T,  eigenvalues l0 <= l1 <= l2
//   normal_i    = eigenvector of l0, oriented towards `viewpoint`
//   curvature_i = l0 / (l0 + l1 + l2)   (surface variation, 0 on a plane, 1/3 isotropic)
// G-ICP (Segal et al. 2009, plane-to-plane): the stored covariance is regularised to
//   C_i' = U diag(epsilon, 1, 1) U^T  (U = eigenvectors, smallest first),
// i.e. unit variance in the local surface and `epsilon` along the normal. The covariances
// are unitless shapes; the Mahalanobis distances built from them are relative, not metric.
// As C_i' = I - (1 - epsilon) u0 u0^T, the pass can keep u0 instead of the matrix (G-ICP
// inverts a pair from the two axes in closed form), and each point's nearest other points,
// with which G-ICP skips searches (CovarianceByproducts below, gicp_cloud.hpp). They cost
// nothing: the eigen solve and the k-NN have them.
//
// Points with fewer than 3 neighbors (tiny clouds) get normal (0,0,0), curvature 1/3 and
// the identity covariance (point-to-point behaviour in G-ICP).
//
// Threading: OpenMP with `num_threads` threads for this call only (never a global setting).

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/kdtree.hpp"
#include "core/common/point_cloud.hpp"

namespace lidarfuse::core {

struct NormalParams {
    int k_neighbors = 15;
    bool compute_normals = true;
    bool compute_covariances = true;
    // Covariance regularisation for G-ICP; false stores the raw neighborhood covariance.
    bool regularize_covariances = true;
    double gicp_epsilon = 1e-3;
    // Normals are flipped to point towards this viewpoint (the sensor origin in the
    // cloud's frame), so that FPFH on different sensors sees consistent signs.
    bool orient_towards_viewpoint = true;
    Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
};

// The G-ICP plane covariance I - (1 - epsilon) a a^T of a unit axis a (the identity for a
// zero one).
inline Eigen::Matrix3d plane_covariance(const Eigen::Vector3d& axis, double epsilon) {
    Eigen::Matrix3d c = -(1.0 - epsilon) * axis * axis.transpose();
    c.diagonal().array() += 1.0;
    return c;
}

struct NormalStats {
    std::size_t num_points = 0;
    std::size_t num_degenerate = 0;  // fewer than 3 neighbors
};

// What the covariance pass knows besides the matrices, kept for G-ICP (gicp_cloud.hpp). Valid
// only with the cloud and covariances of the pass that filled it; a filtered, merged or
// re-sampled cloud has other neighbors and needs a pass of its own.
struct CovarianceByproducts {
    // Each point's kListSize nearest other points (indices, nearest first; n * kListSize
    // entries, padded with the point's own index where the cloud has fewer points) and the
    // squared distance (m^2) within which every other point is listed (infinity when all
    // are). Their reach is limited by k: with k <= kListSize the list holds all k - 1
    // others found.
    static constexpr std::size_t kListSize = 8;
    std::vector<std::uint32_t> neighbor_list;
    std::vector<double> reach_d2;
    // For G-ICP plane covariances, the covariances themselves, as their axes: unit vectors
    // with C_i = I - (1 - plane_epsilon) a a^T (a zero axis for the identity of a degenerate
    // point). G-ICP reads only these, so the pass that fills them writes no matrices
    // (72 bytes a point less to write and to keep). Empty for raw covariances.
    std::vector<Eigen::Vector3d> plane_axes;
    double plane_epsilon = 0.0;

    bool has_neighbor_lists(std::size_t num_points) const {
        return num_points > 0 && reach_d2.size() == num_points &&
               neighbor_list.size() == num_points * kListSize;
    }
    bool has_plane_axes(std::size_t num_points) const {
        return num_points > 0 && plane_axes.size() == num_points && plane_epsilon > 0.0 &&
               plane_epsilon < 1.0;
    }
    // C_i from its axis (has_plane_axes()).
    Eigen::Matrix3d plane_covariance(std::size_t i) const {
        return core::plane_covariance(plane_axes[i], plane_epsilon);
    }
};

// Fills cloud->normals and/or cloud->covariances (as `params` asks) and, when `curvature`
// is not null, the curvature per point. `tree` must be built over cloud->points.
NormalStats estimate_normals_covariances(PointCloud* cloud, const KdTree& tree,
                                         const NormalParams& params,
                                         std::vector<double>* curvature = nullptr,
                                         int num_threads = 1);

// Same (no curvature; `tree` over cloud->points), and fills *byproducts. Plane covariances
// (regularised, 0 < gicp_epsilon < 1) are left as byproducts->plane_axes alone and
// cloud->covariances is emptied; raw ones are written to cloud->covariances as above.
NormalStats estimate_normals_covariances(PointCloud* cloud, CovarianceByproducts* byproducts,
                                         const KdTree& tree, const NormalParams& params,
                                         int num_threads = 1);

// Same as the first, building a temporary k-d tree over cloud->points.
NormalStats estimate_normals_covariances(PointCloud* cloud, const NormalParams& params,
                                         std::vector<double>* curvature = nullptr,
                                         int num_threads = 1);

// The G-ICP plane regularisation of one covariance (see the file comment).
Eigen::Matrix3d regularize_plane_covariance(const Eigen::Matrix3d& covariance, double epsilon);

}  // namespace lidarfuse::core
