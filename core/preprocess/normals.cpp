#include "core/preprocess/normals.hpp"

#include <algorithm>
#include <limits>

#include "core/common/smallest_eigenvector.hpp"

namespace lidarfuse::core {

// U diag(epsilon, 1, 1) U^T = I - (1 - epsilon) u0 u0^T (U orthonormal): u0 is all it needs.
Eigen::Matrix3d regularize_plane_covariance(const Eigen::Matrix3d& covariance, double epsilon) {
    return plane_covariance(smallest_eigenvector(covariance).axis, epsilon);
}

namespace {

// Point i's list from its k-NN result (sorted, i itself among them): the nearest others
// first; the reach is the distance of the first other point not listed, or of the last one
// found when the k-NN stopped short of the list (every unlisted point is at least that
// far), or infinity when the k-NN found the whole cloud.
void record_neighbor_list(std::uint32_t i, const std::uint32_t* idx, const double* d2,
                          std::size_t found, std::size_t cloud_size,
                          CovarianceByproducts* byproducts) {
    constexpr std::size_t kList = CovarianceByproducts::kListSize;
    std::uint32_t* list = byproducts->neighbor_list.data() + static_cast<std::size_t>(i) * kList;
    std::size_t listed = 0;
    double reach = std::numeric_limits<double>::infinity();
    bool reach_set = false;
    for (std::size_t r = 0; r < found; ++r) {
        if (idx[r] == i) continue;
        if (listed == kList) {
            reach = d2[r];
            reach_set = true;
            break;
        }
        list[listed++] = idx[r];
    }
    for (std::size_t r = listed; r < kList; ++r) list[r] = i;
    if (!reach_set && found < cloud_size && found > 0) reach = d2[found - 1];
    byproducts->reach_d2[i] = reach;
}

// Where one call's per-point results go, and which of them it fills.
struct NormalOutputs {
    const NormalParams& params;
    PointCloud* cloud;
    std::vector<double>* curvature;    // may be null
    CovarianceByproducts* byproducts;  // may be null
    bool axes;                         // byproducts->plane_axes: plane covariances
    bool lists;                        // byproducts' neighbor lists: the tree is over this cloud
};

// Sizes the outputs for n points. The plane covariances' axes come with the
// regularisation, the neighbor lists with the k-NN when the tree is over this cloud.
NormalOutputs prepare_outputs(const NormalParams& params, std::size_t tree_size, PointCloud* cloud,
                              std::vector<double>* curvature, CovarianceByproducts* byproducts) {
    const std::size_t n = cloud->points.size();
    if (params.compute_normals) cloud->normals.resize(n);
    if (curvature) curvature->resize(n);
    const bool axes = byproducts && params.compute_covariances && params.regularize_covariances &&
                      params.gicp_epsilon > 0.0 && params.gicp_epsilon < 1.0;
    if (axes) {
        cloud->covariances.clear();  // held as the axes (normals.hpp)
        cloud->covariances.shrink_to_fit();
    } else if (params.compute_covariances) {
        cloud->covariances.resize(n);
    }
    if (!byproducts) return NormalOutputs{params, cloud, curvature, nullptr, false, false};
    *byproducts = CovarianceByproducts();
    if (axes) {
        byproducts->plane_axes.resize(n);
        byproducts->plane_epsilon = params.gicp_epsilon;
    }
    const bool lists = params.compute_covariances && tree_size == n;
    if (lists) {
        byproducts->neighbor_list.resize(n * CovarianceByproducts::kListSize);
        byproducts->reach_d2.resize(n);
    }
    return NormalOutputs{params, cloud, curvature, byproducts, axes, lists};
}

// Fewer than 3 neighbors: no normal, the identity covariance, isotropic curvature.
inline void store_degenerate(const NormalOutputs& out, std::size_t i) {
    if (out.params.compute_normals) out.cloud->normals[i].setZero();
    if (out.axes) {
        out.byproducts->plane_axes[i].setZero();  // the identity (CovarianceByproducts)
    } else if (out.params.compute_covariances) {
        out.cloud->covariances[i].setIdentity();
    }
    if (out.curvature) (*out.curvature)[i] = 1.0 / 3.0;
}

// Covariance of the `found` points idx[] about their mean (m^2). Two-pass (mean first) for
// accuracy far from the origin.
inline Eigen::Matrix3d neighborhood_covariance(const std::vector<Eigen::Vector3d>& points,
                                               const std::uint32_t* idx, std::size_t found) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t j = 0; j < found; ++j) mean += points[idx[j]];
    mean /= static_cast<double>(found);
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (std::size_t j = 0; j < found; ++j) {
        const Eigen::Vector3d d = points[idx[j]] - mean;
        C.noalias() += d * d.transpose();
    }
    C /= static_cast<double>(found);
    return C;
}

// Point i's normal, covariance, plane axis and curvature from its neighborhood covariance C,
// C's eigenvalues and its smallest one's axis.
inline void store_point(const NormalOutputs& out, std::size_t i, const Eigen::Matrix3d& C,
                        const SmallestEigenvector& eigen) {
    const NormalParams& params = out.params;
    if (params.compute_normals) {
        Eigen::Vector3d normal = eigen.axis;
        const Eigen::Vector3d& p = out.cloud->points[i];
        if (params.orient_towards_viewpoint && normal.dot(params.viewpoint - p) < 0.0) {
            normal = -normal;
        }
        out.cloud->normals[i] = normal;
    }
    if (out.axes) {
        out.byproducts->plane_axes[i] = eigen.axis;
    } else if (params.compute_covariances) {
        if (params.regularize_covariances) {
            out.cloud->covariances[i] = plane_covariance(eigen.axis, params.gicp_epsilon);
        } else {
            out.cloud->covariances[i] = C;
        }
    }
    if (out.curvature) {
        const Eigen::Vector3d lambda = eigen.eigenvalues.cwiseMax(0.0);
        const double sum = lambda.sum();
        (*out.curvature)[i] = sum > 0.0 ? lambda(0) / sum : 1.0 / 3.0;
    }
}

// The pass itself: every point's k-NN, covariance and decomposition, into `out`.
NormalStats estimate(const KdTree& tree, int num_threads, const NormalOutputs& out) {
    NormalStats stats;
    PointCloud* cloud = out.cloud;
    const std::size_t n = cloud->points.size();
    stats.num_points = n;
    if (n == 0) return stats;

    const std::size_t k = static_cast<std::size_t>(std::max(3, out.params.k_neighbors));
    const bool own_tree = tree.size() == n;
    const std::vector<std::uint32_t>& order = tree.leaf_order();
    const long long count = static_cast<long long>(n);
    std::size_t degenerate = 0;
#pragma omp parallel num_threads(std::max(1, num_threads)) if (num_threads > 1) \
    reduction(+ : degenerate)
    {
        std::vector<std::uint32_t> idx(k);
        std::vector<double> d2(k);
#pragma omp for schedule(static)
        for (long long t = 0; t < count; ++t) {
            // In the tree's leaf order when the tree is over this cloud (kdtree.hpp).
            const long long i = own_tree ? static_cast<long long>(order[t]) : t;
            const std::size_t found = tree.knn(cloud->points[i], k, idx.data(), d2.data());
            if (out.lists)
                record_neighbor_list(static_cast<std::uint32_t>(i), idx.data(), d2.data(), found, n,
                                     out.byproducts);
            if (found < 3) {
                ++degenerate;
                store_degenerate(out, static_cast<std::size_t>(i));
                continue;
            }
            const Eigen::Matrix3d C = neighborhood_covariance(cloud->points, idx.data(), found);
            store_point(out, static_cast<std::size_t>(i), C, smallest_eigenvector(C));
        }
    }
    stats.num_degenerate = degenerate;
    return stats;
}

}  // namespace

NormalStats estimate_normals_covariances(PointCloud* cloud, const KdTree& tree,
                                         const NormalParams& params, std::vector<double>* curvature,
                                         int num_threads) {
    return estimate(tree, num_threads,
                    prepare_outputs(params, tree.size(), cloud, curvature, nullptr));
}

NormalStats estimate_normals_covariances(PointCloud* cloud, CovarianceByproducts* byproducts,
                                         const KdTree& tree, const NormalParams& params,
                                         int num_threads) {
    return estimate(tree, num_threads,
                    prepare_outputs(params, tree.size(), cloud, nullptr, byproducts));
}

NormalStats estimate_normals_covariances(PointCloud* cloud, const NormalParams& params,
                                         std::vector<double>* curvature, int num_threads) {
    const KdTree tree(cloud->points, 10, num_threads);
    return estimate_normals_covariances(cloud, tree, params, curvature, num_threads);
}

}  // namespace lidarfuse::core
