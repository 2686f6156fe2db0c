#include "core/registration/gicp_cloud.hpp"

namespace lidarfuse::core {

GicpCloud::GicpCloud() : GicpCloud(PointCloud{}) {}

GicpCloud::GicpCloud(PointCloud cloud, int leaf_max_size)
    : GicpCloud(std::move(cloud), CovarianceByproducts{}, leaf_max_size) {}

GicpCloud::GicpCloud(PointCloud cloud, CovarianceByproducts byproducts, int leaf_max_size)
    : cloud_(std::make_unique<PointCloud>(std::move(cloud))),
      byproducts_(std::move(byproducts)),
      tree_(std::make_unique<KdTree>(cloud_->points, leaf_max_size)),
      leaf_max_size_(leaf_max_size) {}

GicpCloud::GicpCloud(PointCloud cloud, const NormalParams& covariances, int leaf_max_size,
                     int num_threads)
    : cloud_(std::make_unique<PointCloud>(std::move(cloud))),
      tree_(std::make_unique<KdTree>(cloud_->points, leaf_max_size, num_threads)),
      leaf_max_size_(leaf_max_size) {
    // Only the covariances change, never the points the tree refers to.
    estimate_normals_covariances(cloud_.get(), &byproducts_, *tree_, covariances, num_threads);
}

GicpCloud::GicpCloud(GicpCloud&&) noexcept = default;
GicpCloud& GicpCloud::operator=(GicpCloud&&) noexcept = default;
GicpCloud::~GicpCloud() = default;

PointCloud GicpCloud::cloud_with_covariance_matrices() const {
    PointCloud out = *cloud_;
    if (!has_covariances()) return out;
    out.covariances.resize(size());
    for (std::size_t i = 0; i < size(); ++i) out.covariances[i] = covariance(i);
    return out;
}

GicpCloud GicpCloud::clone() const { return GicpCloud(*cloud_, byproducts_, leaf_max_size_); }

}  // namespace lidarfuse::core
