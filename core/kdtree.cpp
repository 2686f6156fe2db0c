#include "core/kdtree.hpp"

#include <nanoflann.hpp>

#include <limits>

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

using Tree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, VectorAdaptor>,
                                        VectorAdaptor, 3, std::uint32_t>;

// A one-nearest result set that starts with an upper bound instead of infinity: the
// search prunes every node farther than the best distance so far, so a tight start bound
// skips most of the tree. Interface as nanoflann 1.4.3's searchLevel uses it.
class BoundedNearestResult {
public:
    explicit BoundedNearestResult(double max_squared_distance) : best_d2_(max_squared_distance) {}
    std::size_t size() const { return found_ ? 1 : 0; }
    bool full() const { return true; }
    bool addPoint(double d2, std::uint32_t index) {
        if (d2 < best_d2_) {
            best_d2_ = d2;
            best_index_ = index;
            found_ = true;
        }
        return true;
    }
    double worstDist() const { return best_d2_; }
    bool found() const { return found_; }
    std::uint32_t index() const { return best_index_; }

private:
    double best_d2_;
    std::uint32_t best_index_ = 0;
    bool found_ = false;
};

}  // namespace

struct KdTree::Impl {
    VectorAdaptor adaptor;
    Tree tree;
    Impl(const std::vector<Eigen::Vector3d>& points, int leaf_max_size)
        : adaptor{&points},
          tree(3, adaptor,
               nanoflann::KDTreeSingleIndexAdaptorParams(static_cast<std::size_t>(leaf_max_size))) {
    }
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
    // The same search and tie rule as a 1-nearest knn (the first point met at the smallest
    // distance wins), without the k-sorted result set.
    return nearest_within(query, std::numeric_limits<double>::infinity(), index,
                          squared_distance);
}

bool KdTree::nearest_within(const Eigen::Vector3d& query, double max_squared_distance,
                            std::uint32_t* index, double* squared_distance) const {
    if (size() == 0 || !(max_squared_distance > 0.0)) return false;
    BoundedNearestResult result(max_squared_distance);
    impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
    if (!result.found()) return false;
    *index = result.index();
    *squared_distance = result.worstDist();
    return true;
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
