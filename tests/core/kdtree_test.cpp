#include "core/common/kdtree.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace lidarfuse::core {
namespace {

std::vector<Eigen::Vector3d> random_points(std::size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-10.0, 10.0);
    std::vector<Eigen::Vector3d> points(n);
    for (auto& p : points) p = {u(rng), u(rng), u(rng)};
    return points;
}

// Every query against brute force: the k nearest and the radius set must agree exactly.
TEST(KdTree, KnnAndRadiusMatchBruteForce) {
    const auto points = random_points(2000, 7);
    const auto queries = random_points(200, 8);
    KdTree tree(points);
    ASSERT_EQ(tree.size(), points.size());
    std::vector<std::pair<std::uint32_t, double>> found;
    for (const auto& q : queries) {
        std::vector<std::pair<double, std::uint32_t>> brute;
        for (std::uint32_t i = 0; i < points.size(); ++i) {
            brute.emplace_back((points[i] - q).squaredNorm(), i);
        }
        std::sort(brute.begin(), brute.end());

        constexpr std::size_t kNeighbors = 8;
        std::uint32_t idx[kNeighbors];
        double d2[kNeighbors];
        ASSERT_EQ(tree.knn(q, kNeighbors, idx, d2), kNeighbors);
        for (std::size_t j = 0; j < kNeighbors; ++j) {
            EXPECT_EQ(idx[j], brute[j].second);
            EXPECT_DOUBLE_EQ(d2[j], brute[j].first);
        }

        const double r = 2.5;
        tree.radius(q, r, &found);
        const auto expected = std::count_if(brute.begin(), brute.end(),
                                            [&](const auto& b) { return b.first <= r * r; });
        ASSERT_EQ(static_cast<long>(found.size()), expected);
        for (std::size_t j = 0; j < found.size(); ++j) {
            EXPECT_EQ(found[j].first, brute[j].second);
        }
    }
}

// The bounded search finds exactly the brute-force nearest when it lies inside the
// bound, and nothing otherwise, for bounds from tight to loose.
TEST(KdTree, NearestWithinMatchesBruteForce) {
    const auto points = random_points(3000, 11);
    const auto queries = random_points(300, 12);
    KdTree tree(points);
    int inside = 0, outside = 0;
    for (const auto& q : queries) {
        double best = 1e300;
        std::uint32_t best_i = 0;
        for (std::uint32_t i = 0; i < points.size(); ++i) {
            const double d2 = (points[i] - q).squaredNorm();
            if (d2 < best) best = d2, best_i = i;
        }
        for (const double bound : {0.05, 0.3, 1.0, 4.0, 1e9}) {
            std::uint32_t idx = 0;
            double d2 = -1.0;
            const bool found = tree.nearest_within(q, bound, &idx, &d2);
            if (best < bound) {
                ASSERT_TRUE(found) << "bound " << bound;
                EXPECT_EQ(idx, best_i);
                EXPECT_DOUBLE_EQ(d2, best);
                ++inside;
            } else {
                EXPECT_FALSE(found) << "bound " << bound << " nearest " << best;
                ++outside;
            }
        }
    }
    // Both branches were exercised.
    EXPECT_GT(inside, 300);
    EXPECT_GT(outside, 100);
    std::uint32_t idx = 0;
    double d2 = 0.0;
    EXPECT_FALSE(tree.nearest_within(queries[0], 0.0, &idx, &d2));
}

// nearest() is nearest_within() without a bound: the brute-force nearest, and the same
// point a 1-nearest knn() picks, also among exact duplicates (ties).
TEST(KdTree, NearestMatchesBruteForceAndKnnOne) {
    auto points = random_points(2000, 21);
    for (std::size_t i = 0; i < 200; ++i) points.push_back(points[i * 7]);  // duplicates
    const auto queries = random_points(300, 22);
    KdTree tree(points);
    for (std::size_t qi = 0; qi < queries.size() + 50; ++qi) {
        // The last queries sit exactly on duplicated points (two points at distance 0).
        const Eigen::Vector3d q = qi < queries.size() ? queries[qi] : points[(qi - 300) * 7];
        double best = 1e300;
        for (const auto& p : points) best = std::min(best, (p - q).squaredNorm());
        std::uint32_t idx = 0, idx1 = 0;
        double d2 = -1.0, d2_1 = -1.0;
        ASSERT_TRUE(tree.nearest(q, &idx, &d2));
        ASSERT_EQ(tree.knn(q, 1, &idx1, &d2_1), 1u);
        EXPECT_DOUBLE_EQ(d2, best);
        EXPECT_DOUBLE_EQ((points[idx] - q).squaredNorm(), best);
        EXPECT_EQ(idx, idx1);
        EXPECT_EQ(d2, d2_1);
    }
}

// A tree built with two threads (its upper subtrees as parallel tasks) is the serial tree:
// every query gets the same answer, also among duplicates.
TEST(KdTree, ParallelBuildAnswersAsTheSerialOne) {
    auto points = random_points(40000, 31);
    for (std::size_t i = 0; i < 1000; ++i) points.push_back(points[i * 13]);
    const auto queries = random_points(500, 32);
    const KdTree serial(points, 10, 1);
    const KdTree parallel(points, 10, 2);
    ASSERT_EQ(parallel.size(), points.size());
    constexpr std::size_t kNeighbors = 12;
    for (const auto& q : queries) {
        std::uint32_t ia[kNeighbors], ib[kNeighbors];
        double da[kNeighbors], db[kNeighbors];
        ASSERT_EQ(serial.knn(q, kNeighbors, ia, da), kNeighbors);
        ASSERT_EQ(parallel.knn(q, kNeighbors, ib, db), kNeighbors);
        for (std::size_t j = 0; j < kNeighbors; ++j) {
            EXPECT_EQ(ia[j], ib[j]);
            EXPECT_EQ(da[j], db[j]);
        }
    }
}

TEST(KdTree, EmptyTreeAnswersNothing) {
    std::vector<Eigen::Vector3d> none;
    KdTree tree(none);
    std::uint32_t idx = 0;
    double d2 = 0;
    EXPECT_FALSE(tree.nearest(Eigen::Vector3d::Zero(), &idx, &d2));
    EXPECT_FALSE(tree.nearest_within(Eigen::Vector3d::Zero(), 1.0, &idx, &d2));
    std::vector<std::pair<std::uint32_t, double>> found;
    EXPECT_EQ(tree.radius(Eigen::Vector3d::Zero(), 1.0, &found), 0u);
}

}  // namespace
}  // namespace lidarfuse::core
