#pragma once
// A cloud ready for G-ICP (gicp.hpp), on either side of a registration: the points with
// their covariances (normals.hpp), the k-d tree over the points, and what the covariance
// pass left for G-ICP (CovarianceByproducts: the neighbor lists that spare the
// correspondence search, the plane axes that invert a covariance pair in closed form).
// A frame's cloud is the target of some edges and the source of others, so one type
// serves both sides. Immutable after construction: one cloud serves many registrations
// and threads at once. Movable; the points stay at a fixed address inside.

#include <cstddef>
#include <memory>

#include "core/common/kdtree.hpp"
#include "core/common/point_cloud.hpp"
#include "core/preprocess/normals.hpp"

namespace lidarfuse::core {

class GicpCloud {
public:
    GicpCloud();
    // Takes the cloud as it is (move it in to avoid a copy). Covariances it carries are
    // used as plain matrices: G-ICP's searches and inverses take the general path.
    explicit GicpCloud(PointCloud cloud, int leaf_max_size = 10);
    // Takes the cloud and the byproducts of the pass that computed its covariances.
    GicpCloud(PointCloud cloud, CovarianceByproducts byproducts, int leaf_max_size = 10);
    // Takes the cloud and computes its covariances and their byproducts as `covariances`
    // asks, on this cloud's own k-d tree: the tree and the covariances on `num_threads`
    // OpenMP threads.
    GicpCloud(PointCloud cloud, const NormalParams& covariances, int leaf_max_size = 10,
              int num_threads = 1);
    GicpCloud(GicpCloud&&) noexcept;
    GicpCloud& operator=(GicpCloud&&) noexcept;
    ~GicpCloud();

    // A deep copy with a tree of its own (explicit: a copy costs a tree build).
    GicpCloud clone() const;

    const PointCloud& cloud() const { return *cloud_; }
    const std::vector<Eigen::Vector3d>& points() const { return cloud_->points; }
    const KdTree& tree() const { return *tree_; }
    const CovarianceByproducts& byproducts() const { return byproducts_; }
    std::size_t size() const { return cloud_->size(); }
    bool empty() const { return cloud_->empty(); }
    // Covariances as matrices (cloud().covariances) or as plane axes alone (byproducts()).
    bool has_covariances() const {
        return cloud_->has_covariances() || byproducts_.has_plane_axes(size());
    }
    bool has_neighbor_lists() const { return byproducts_.has_neighbor_lists(size()); }
    // Covariances of the form I - (1 - epsilon) a a^T, held as their axes a (the covariance
    // pass leaves cloud().covariances empty then: normals.hpp).
    bool has_plane_covariances() const { return byproducts_.has_plane_axes(size()); }
    // Point i's covariance as a matrix, whichever way it is held (has_covariances()).
    Eigen::Matrix3d covariance(std::size_t i) const {
        return has_plane_covariances() ? byproducts_.plane_covariance(i) : cloud_->covariances[i];
    }
    // A copy of the cloud with every covariance as a matrix (for code that wants matrices,
    // such as another library's G-ICP given ours).
    PointCloud cloud_with_covariance_matrices() const;

private:
    std::unique_ptr<PointCloud> cloud_;
    CovarianceByproducts byproducts_;
    std::unique_ptr<KdTree> tree_;
    int leaf_max_size_ = 10;
};

}  // namespace lidarfuse::core
