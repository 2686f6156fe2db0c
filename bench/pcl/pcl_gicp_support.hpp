#pragma once
// What the PCL benches share (bench/pcl, built only with -DLIDARFUSE_WITH_PCL=ON): our points
// as PCL's float cloud, and PCL's GICP with its protected iteration count and covariance
// step opened up.

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#include <pcl/search/kdtree.h>

#include <Eigen/Core>
#include <vector>

namespace lidarfuse::bench {

inline pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl(const std::vector<Eigen::Vector3d>& points) {
    auto out = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    out->reserve(points.size());
    for (const Eigen::Vector3d& p : points) {
        out->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()),
                                     static_cast<float>(p.z())));
    }
    return out;
}

// PCL 1.13 keeps the iteration count in a protected member with no getter, and its
// covariance step in a protected method.
class CountingGicp : public pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> {
public:
    int iterations() const { return nr_iterations_; }
    void covariances(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud,
                     const pcl::search::KdTree<pcl::PointXYZ>::Ptr& tree, MatricesVector* out) {
        computeCovariances<pcl::PointXYZ>(cloud, tree, *out);
    }
};

}  // namespace lidarfuse::bench
