#include "core/common/kdtree.hpp"

#include <algorithm>
#include <limits>
#include <numeric>

namespace lidarfuse::core {

namespace {

// An inner node splits its points on one axis: the left child (the next node) holds the
// points with coordinate <= low, the right child (node `right`) those >= high, low <=
// high. A leaf holds the points [begin, end) of the leaf-ordered copy.
struct Node {
    double low = 0.0;
    double high = 0.0;
    std::uint32_t right_or_begin = 0;
    std::uint32_t end = 0;
    int axis = -1;  // -1: leaf
};

// The same summation order everywhere (x, then y, then z), so that a distance compared
// in the search and the one returned are the same number.
inline double squared_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    const double dx = a.x() - b.x();
    const double dy = a.y() - b.y();
    const double dz = a.z() - b.z();
    return dx * dx + dy * dy + dz * dz;
}

// Ties between equally distant points go to the smaller index, whatever the tree's shape
// (a lattice of points, or duplicates, has many).
inline bool before(double d2, std::uint32_t index, double other_d2, std::uint32_t other_index) {
    return d2 < other_d2 || (d2 == other_d2 && index < other_index);
}

// The k best so far, in (distance, index) order.
class KnnResult {
public:
    KnnResult(std::size_t k, std::uint32_t* indices, double* d2) : k_(k), idx_(indices), d2_(d2) {}
    double worst() const {
        return count_ < k_ ? std::numeric_limits<double>::infinity() : d2_[k_ - 1];
    }
    void add(double d2, std::uint32_t index) {
        if (count_ == k_ && !before(d2, index, d2_[k_ - 1], idx_[k_ - 1])) return;
        std::size_t i = count_ < k_ ? count_++ : k_ - 1;
        for (; i > 0 && before(d2, index, d2_[i - 1], idx_[i - 1]); --i) {
            d2_[i] = d2_[i - 1];
            idx_[i] = idx_[i - 1];
        }
        d2_[i] = d2;
        idx_[i] = index;
    }
    std::size_t count() const { return count_; }

private:
    std::size_t k_;
    std::uint32_t* idx_;
    double* d2_;
    std::size_t count_ = 0;
};

// The nearest point strictly closer than a start bound (m^2).
class NearestResult {
public:
    explicit NearestResult(double bound) : best_(bound) {}
    double worst() const { return best_; }
    void add(double d2, std::uint32_t index) {
        if (d2 == best_ && (!found_ || index > index_)) return;
        best_ = d2;
        index_ = index;
        found_ = true;
    }
    bool found() const { return found_; }
    std::uint32_t index() const { return index_; }

private:
    double best_;
    std::uint32_t index_ = 0;
    bool found_ = false;
};

// Every point strictly closer than the radius (m^2); the bound never shrinks.
class RadiusResult {
public:
    RadiusResult(double r2, std::vector<std::pair<std::uint32_t, double>>* out)
        : r2_(r2), out_(out) {}
    double worst() const { return r2_; }
    void add(double d2, std::uint32_t index) {
        if (d2 < r2_) out_->emplace_back(index, d2);
    }

private:
    double r2_;
    std::vector<std::pair<std::uint32_t, double>>* out_;
};

}  // namespace

struct KdTree::Impl {
    std::vector<Eigen::Vector3d> points;  // leaf order
    std::vector<std::uint32_t> original;  // the caller's index of each
    std::vector<Node> nodes;              // depth first, node 0 the root
    std::uint32_t leaf_size = 10;

    void build(const std::vector<Eigen::Vector3d>& input, int num_threads);
    std::uint32_t split(std::uint32_t begin, std::uint32_t end, Node* node);
    void build_serial(std::uint32_t begin, std::uint32_t end, std::vector<Node>* out);
    std::vector<Node> build_parallel(std::uint32_t begin, std::uint32_t end, int levels);

    template <class Result>
    void search(std::uint32_t node, const Eigen::Vector3d& q, double min_d2, Eigen::Vector3d& cut,
                Result& result) const;
};

// Splits [begin, end) at the middle of its widest extent (points below the middle first);
// returns the first index of the right half, or `begin` when the range stays a leaf: all
// its points equal, or all on one side of the middle (rounding between two neighbors).
std::uint32_t KdTree::Impl::split(std::uint32_t begin, std::uint32_t end, Node* node) {
    Eigen::Vector3d lo = points[begin], hi = points[begin];
    for (std::uint32_t i = begin + 1; i < end; ++i) {
        lo = lo.cwiseMin(points[i]);
        hi = hi.cwiseMax(points[i]);
    }
    int axis = 0;
    (hi - lo).maxCoeff(&axis);
    const double middle = 0.5 * (lo[axis] + hi[axis]);
    std::uint32_t left = begin;
    for (std::uint32_t i = begin; i < end; ++i) {
        if (points[i][axis] < middle) {
            std::swap(points[i], points[left]);
            std::swap(original[i], original[left]);
            ++left;
        }
    }
    if (left == begin || left == end) return begin;
    node->axis = axis;
    node->low = lo[axis];
    for (std::uint32_t i = begin; i < left; ++i) node->low = std::max(node->low, points[i][axis]);
    node->high = hi[axis];
    for (std::uint32_t i = left; i < end; ++i) node->high = std::min(node->high, points[i][axis]);
    return left;
}

// Appends the subtree of [begin, end) to `out`, depth first; child links are indices
// into `out`.
void KdTree::Impl::build_serial(std::uint32_t begin, std::uint32_t end, std::vector<Node>* out) {
    const auto self = out->size();
    out->emplace_back();
    Node node;
    const std::uint32_t middle = end - begin > leaf_size ? split(begin, end, &node) : begin;
    if (middle == begin) {
        node.axis = -1;
        node.right_or_begin = begin;
        node.end = end;
    } else {
        build_serial(begin, middle, out);
        node.right_or_begin = static_cast<std::uint32_t>(out->size());
        build_serial(middle, end, out);
    }
    (*out)[self] = node;
}

// The top `levels` levels split here, their subtrees built as OpenMP tasks, then joined:
// a subtree's child links are relative to its own first node until it is placed.
std::vector<Node> KdTree::Impl::build_parallel(std::uint32_t begin, std::uint32_t end, int levels) {
    std::vector<Node> out;
    Node node;
    const std::uint32_t middle =
        levels > 0 && end - begin > leaf_size ? split(begin, end, &node) : begin;
    if (middle == begin) {
        build_serial(begin, end, &out);
        return out;
    }
    std::vector<Node> left, right;
#pragma omp task shared(left)
    left = build_parallel(begin, middle, levels - 1);
#pragma omp task shared(right)
    right = build_parallel(middle, end, levels - 1);
#pragma omp taskwait
    const auto place = [&out](const std::vector<Node>& part) {
        const auto offset = static_cast<std::uint32_t>(out.size());
        for (Node n : part) {
            if (n.axis >= 0) n.right_or_begin += offset;
            out.push_back(n);
        }
    };
    out.reserve(1 + left.size() + right.size());
    out.push_back(node);
    place(left);
    out[0].right_or_begin = static_cast<std::uint32_t>(out.size());
    place(right);
    return out;
}

void KdTree::Impl::build(const std::vector<Eigen::Vector3d>& input, int num_threads) {
    points = input;
    original.resize(input.size());
    std::iota(original.begin(), original.end(), 0u);
    nodes.clear();
    if (points.empty()) return;
    const auto n = static_cast<std::uint32_t>(points.size());
    // Below a few tens of thousands of points the tasks cost more than they save.
    constexpr std::uint32_t kParallelFrom = 8192;
    if (num_threads <= 1 || n < kParallelFrom) {
        nodes.reserve(2 * (n / leaf_size + 1));
        build_serial(0, n, &nodes);
        return;
    }
    int levels = 0;
    while ((1 << levels) < 4 * num_threads) ++levels;
#pragma omp parallel num_threads(num_threads)
#pragma omp single
    nodes = build_parallel(0, n, levels);
}

// Depth first, the query's side first (a far side at exactly the best distance is still
// visited: it may hold a tie with a smaller index); `cut` holds, per axis, the squared distance
// from the query to the cell's slab on that axis (0 inside), `min_d2` their sum: a lower bound on
// the distance to any point of the node.
template <class Result>
void KdTree::Impl::search(std::uint32_t n, const Eigen::Vector3d& q, double min_d2,
                          Eigen::Vector3d& cut, Result& result) const {
    const Node& node = nodes[n];
    if (node.axis < 0) {
        for (std::uint32_t i = node.right_or_begin; i < node.end; ++i) {
            const double d2 = squared_distance(points[i], q);
            if (d2 <= result.worst()) result.add(d2, original[i]);
        }
        return;
    }
    const int axis = node.axis;
    const double to_low = q[axis] - node.low;
    const double to_high = q[axis] - node.high;
    const bool left_first = to_low + to_high < 0.0;
    const std::uint32_t near = left_first ? n + 1 : node.right_or_begin;
    const std::uint32_t far = left_first ? node.right_or_begin : n + 1;
    const double far_cut = left_first ? to_high * to_high : to_low * to_low;
    search(near, q, min_d2, cut, result);
    const double saved = cut[axis];
    const double far_min_d2 = min_d2 + far_cut - saved;
    if (far_min_d2 <= result.worst()) {
        cut[axis] = far_cut;
        search(far, q, far_min_d2, cut, result);
        cut[axis] = saved;
    }
}

KdTree::KdTree(const std::vector<Eigen::Vector3d>& points, int leaf_max_size, int num_threads)
    : impl_(std::make_unique<Impl>()) {
    impl_->leaf_size = static_cast<std::uint32_t>(std::max(1, leaf_max_size));
    impl_->build(points, num_threads);
}

KdTree::~KdTree() = default;

std::size_t KdTree::size() const { return impl_->points.size(); }

const std::vector<std::uint32_t>& KdTree::leaf_order() const { return impl_->original; }

std::size_t KdTree::knn(const Eigen::Vector3d& query, std::size_t k, std::uint32_t* indices,
                        double* squared_distances) const {
    if (k == 0 || size() == 0) return 0;
    KnnResult result(k, indices, squared_distances);
    Eigen::Vector3d cut = Eigen::Vector3d::Zero();
    impl_->search(0, query, 0.0, cut, result);
    return result.count();
}

bool KdTree::nearest(const Eigen::Vector3d& query, std::uint32_t* index,
                     double* squared_distance) const {
    // The same search and tie rule as a 1-nearest knn (the first point met at the smallest
    // distance wins), without the k-sorted result set.
    return nearest_within(query, std::numeric_limits<double>::infinity(), index, squared_distance);
}

bool KdTree::nearest_within(const Eigen::Vector3d& query, double max_squared_distance,
                            std::uint32_t* index, double* squared_distance) const {
    if (size() == 0 || !(max_squared_distance > 0.0)) return false;
    NearestResult result(max_squared_distance);
    Eigen::Vector3d cut = Eigen::Vector3d::Zero();
    impl_->search(0, query, 0.0, cut, result);
    if (!result.found()) return false;
    *index = result.index();
    *squared_distance = result.worst();
    return true;
}

std::size_t KdTree::radius(const Eigen::Vector3d& query, double radius_m,
                           std::vector<std::pair<std::uint32_t, double>>* out) const {
    out->clear();
    if (size() == 0) return 0;
    RadiusResult result(radius_m * radius_m, out);
    Eigen::Vector3d cut = Eigen::Vector3d::Zero();
    impl_->search(0, query, 0.0, cut, result);
    std::sort(out->begin(), out->end(), [](const auto& a, const auto& b) {
        return a.second < b.second || (a.second == b.second && a.first < b.first);
    });
    return out->size();
}

}  // namespace lidarfuse::core
