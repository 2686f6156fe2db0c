#include "core/kdtree.hpp"

#include <nanoflann.hpp>

namespace lidarfuse::core {

namespace {

// nanoflann's dataset adaptor over std::vector<Eigen::Vector3d>.
struct VectorAdaptor {
    const std::vector<Eigen::Vector3d>* points;
    std::size_t kdtree_get_point_count() const { return points->size(); }
    double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*points)[i][dim]; }
    template <class BoundingBox>
    bool kdtree_get_bbox(BoundingBox&) const {
        return false;
    }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, VectorAdaptor>,
                                                 VectorAdaptor, 3, std::uint32_t>;

}  // namespace

struct KdTree::Impl {
    VectorAdaptor adaptor;
    Tree tree;
    Impl(const std::vector<Eigen::Vector3d>& points, int leaf_max_size)
        : adaptor{&points},
          tree(3, adaptor,
               nanoflann::KDTreeSingleIndexAdaptorParams(static_cast<std::size_t>(leaf_max_size))) {}
};

KdTree::KdTree(const std::vector<Eigen::Vector3d>& points, int leaf_max_size)
    : impl_(std::make_unique<Impl>(points, leaf_max_size)) {}

KdTree::~KdTree() = default;

std::size_t KdTree::size() const { return impl_->adaptor.points->size(); }

std::size_t KdTree::knn(const Eigen::Vector3d& query, std::size_t k, std::uint32_t* indices,
                        double* squared_distances) const {
    if (k == 0 || size() == 0) return 0;
    nanoflann::KNNResultSet<double, std::uint32_t> result(k);
    result.init(indices, squared_distances);
    impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
    return result.size();
}

bool KdTree::nearest(const Eigen::Vector3d& query, std::uint32_t* index,
                     double* squared_distance) const {
    return knn(query, 1, index, squared_distance) == 1;
}

std::size_t KdTree::radius(const Eigen::Vector3d& query, double radius_m,
                           std::vector<std::pair<std::uint32_t, double>>* out) const {
    out->clear();
    if (size() == 0) return 0;
    // nanoflann's L2_Simple metric works on squared distances, radius included.
    nanoflann::SearchParams params;
    params.sorted = true;
    return impl_->tree.radiusSearch(query.data(), radius_m * radius_m, *out, params);
}

}  // namespace lidarfuse::core
