#include "core/preprocess/normals.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <limits>
#include <random>

#include "tests/core/synthetic_scene.hpp"

namespace lidarfuse::core {
namespace {

TEST(Normals, PlaneNormalsCurvatureAndRegularisedCovariance) {
    std::mt19937 rng(3);
    PointCloud cloud;
    // A tilted plane through (0, 0, 5) with normal n.
    const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
    const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
    test::sample_rectangle(rng, Eigen::Vector3d(0, 0, 5) - 5 * u - 5 * v, 10 * u, 10 * v, 2000,
                           &cloud.points);
    NormalParams params;
    std::vector<double> curvature;
    const NormalStats stats = estimate_normals_covariances(&cloud, params, &curvature, 2);
    EXPECT_EQ(stats.num_degenerate, 0u);
    ASSERT_TRUE(cloud.has_normals());
    ASSERT_TRUE(cloud.has_covariances());
    ASSERT_EQ(curvature.size(), cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        // Oriented towards the viewpoint (origin, below the plane): n . (0 - p) > 0.
        EXPECT_GT(cloud.normals[i].dot(-cloud.points[i]), 0.0);
        EXPECT_NEAR(std::abs(cloud.normals[i].dot(n)), 1.0, 1e-9);
        EXPECT_LT(curvature[i], 1e-9);
        // Regularised: eigenvalues (eps, 1, 1) with the eps direction along the normal.
        EXPECT_NEAR(n.dot(cloud.covariances[i] * n), params.gicp_epsilon, 1e-9);
        EXPECT_NEAR(u.dot(cloud.covariances[i] * u), 1.0, 1e-9);
        EXPECT_NEAR(cloud.covariances[i].trace(), 2.0 + params.gicp_epsilon, 1e-9);
    }
}

TEST(Normals, IsotropicBlobHasHighCurvatureAndRawCovarianceOption) {
    std::mt19937 rng(4);
    std::normal_distribution<double> g(0.0, 0.1);
    PointCloud cloud;
    for (int i = 0; i < 3000; ++i) cloud.points.emplace_back(g(rng), g(rng), g(rng));
    NormalParams params;
    params.k_neighbors = 30;
    params.regularize_covariances = false;
    params.compute_normals = false;
    std::vector<double> curvature;
    estimate_normals_covariances(&cloud, params, &curvature);
    EXPECT_TRUE(cloud.normals.empty());
    double mean = 0.0;
    for (const double c : curvature) mean += c;
    mean /= static_cast<double>(curvature.size());
    EXPECT_GT(mean, 0.1);  // far from a plane's 0 (max 1/3)
    EXPECT_LE(*std::max_element(curvature.begin(), curvature.end()), 1.0 / 3.0 + 1e-12);
    // Raw covariances are neighborhood scatter: small, not the (eps, 1, 1) shape.
    EXPECT_LT(cloud.covariances[0].trace(), 0.1);
}

// The covariances' byproducts, computed on a tree over `cloud` itself.
CovarianceByproducts byproducts_of(PointCloud* cloud, const NormalParams& params) {
    const KdTree tree(cloud->points);
    CovarianceByproducts byproducts;
    estimate_normals_covariances(cloud, &byproducts, tree, params, 2);
    return byproducts;
}

// Neither the thread count nor keeping the byproducts changes the normals or covariances;
// with the byproducts the plane covariances are their axes alone, the same matrices to the
// bit, and no matrix is written.
TEST(Normals, ThreadCountAndByproductsDoNotChangeTheResult) {
    std::mt19937 rng(5);
    PointCloud a;
    a.points = test::make_structured_scene(rng, 1.0);
    PointCloud b = a, c = a;
    c.covariances.assign(c.size(), Eigen::Matrix3d::Zero());  // stale ones go
    NormalParams params;
    estimate_normals_covariances(&a, params, nullptr, 1);
    estimate_normals_covariances(&b, params, nullptr, 2);
    const CovarianceByproducts planes = byproducts_of(&c, params);
    ASSERT_TRUE(planes.has_plane_axes(c.size()));
    EXPECT_TRUE(c.covariances.empty());
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a.normals[i], b.normals[i]);
        EXPECT_EQ(a.covariances[i], b.covariances[i]);
        EXPECT_EQ(a.normals[i], c.normals[i]);
        EXPECT_EQ(a.covariances[i], planes.plane_covariance(i));
    }
}

// The k-NN pass records each point's nearest other points (for G-ICP's search shortcut):
// the brute-force order, duplicates included, every unlisted point at least `reach` away,
// the whole cloud listed (reach infinite) when it is that small; absent without
// covariances.
TEST(Normals, NeighborListsComeWithTheCovariances) {
    constexpr std::size_t kList = CovarianceByproducts::kListSize;
    std::mt19937 rng(11);
    PointCloud cloud;
    cloud.points = test::make_structured_scene(rng, 1.0);
    cloud.points.push_back(cloud.points[7]);  // a duplicate of point 7
    NormalParams params;
    const CovarianceByproducts lists = byproducts_of(&cloud, params);
    const std::size_t n = cloud.size();
    ASSERT_TRUE(lists.has_neighbor_lists(n));
    for (std::size_t i = 0; i < n; ++i) {
        std::vector<std::pair<double, std::size_t>> others;
        for (std::size_t j = 0; j < n; ++j) {
            if (j != i) others.emplace_back((cloud.points[j] - cloud.points[i]).squaredNorm(), j);
        }
        std::sort(others.begin(), others.end());
        const std::uint32_t* list = &lists.neighbor_list[i * kList];
        for (std::size_t r = 0; r < kList; ++r) {
            ASSERT_DOUBLE_EQ((cloud.points[list[r]] - cloud.points[i]).squaredNorm(),
                             others[r].first)
                << "point " << i << " rank " << r;
        }
        ASSERT_DOUBLE_EQ(lists.reach_d2[i], others[kList].first) << "point " << i;
    }
    EXPECT_EQ(lists.neighbor_list[7 * kList], n - 1);  // the duplicate is 7's nearest
    EXPECT_EQ(lists.neighbor_list[(n - 1) * kList], 7u);

    PointCloud tiny;
    tiny.points = {{0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {0, 0, 3}};
    const CovarianceByproducts tiny_lists = byproducts_of(&tiny, params);
    ASSERT_TRUE(tiny_lists.has_neighbor_lists(tiny.size()));
    EXPECT_EQ(tiny_lists.neighbor_list[0], 1u);
    EXPECT_EQ(tiny_lists.neighbor_list[1], 2u);
    EXPECT_EQ(tiny_lists.neighbor_list[2], 3u);
    EXPECT_EQ(tiny_lists.neighbor_list[3], 0u);  // padded with the point itself
    EXPECT_TRUE(std::isinf(tiny_lists.reach_d2[0]));

    PointCloud normals_only;
    normals_only.points = cloud.points;
    params.compute_covariances = false;
    EXPECT_FALSE(byproducts_of(&normals_only, params).has_neighbor_lists(n));
}

TEST(Normals, TinyCloudsAreDegenerateButFinite) {
    PointCloud cloud;
    cloud.points = {{0, 0, 0}, {1, 0, 0}};
    std::vector<double> curvature;
    const NormalStats stats = estimate_normals_covariances(&cloud, NormalParams{}, &curvature);
    EXPECT_EQ(stats.num_degenerate, 2u);
    EXPECT_EQ(cloud.normals[0], Eigen::Vector3d::Zero());
    EXPECT_TRUE(cloud.covariances[1].isIdentity());
    EXPECT_DOUBLE_EQ(curvature[0], 1.0 / 3.0);
    PointCloud empty;
    EXPECT_EQ(estimate_normals_covariances(&empty, NormalParams{}).num_points, 0u);
}

// The regularised covariances come with their axes: C = I - (1 - epsilon) a a^T, a unit
// (zero for a degenerate point's identity); raw covariances come without.
TEST(Normals, PlaneCovariancesComeWithTheirAxes) {
    std::mt19937 rng(5);
    PointCloud cloud;
    cloud.points = test::make_structured_scene(rng, 1.0);
    NormalParams params;
    params.gicp_epsilon = 0.02;
    const CovarianceByproducts planes = byproducts_of(&cloud, params);
    ASSERT_TRUE(planes.has_plane_axes(cloud.size()));
    EXPECT_DOUBLE_EQ(planes.plane_epsilon, 0.02);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        const Eigen::Vector3d& a = planes.plane_axes[i];
        ASSERT_NEAR(a.norm(), 1.0, 1e-12) << "point " << i;
        const Eigen::Matrix3d C = Eigen::Matrix3d::Identity() - 0.98 * a * a.transpose();
        ASSERT_TRUE(C.isApprox(planes.plane_covariance(i), 1e-12)) << "point " << i;
        ASSERT_NEAR(std::abs(a.dot(cloud.normals[i])), 1.0, 1e-12) << "point " << i;
    }

    PointCloud tiny;
    tiny.points = {{0, 0, 0}, {1, 0, 0}};
    const CovarianceByproducts tiny_planes = byproducts_of(&tiny, params);
    ASSERT_TRUE(tiny_planes.has_plane_axes(tiny.size()));
    EXPECT_EQ(tiny_planes.plane_axes[0], Eigen::Vector3d::Zero());
    EXPECT_EQ(tiny_planes.plane_covariance(0), Eigen::Matrix3d::Identity());

    params.regularize_covariances = false;
    const CovarianceByproducts raw = byproducts_of(&cloud, params);
    EXPECT_TRUE(cloud.has_covariances());
    EXPECT_FALSE(raw.has_plane_axes(cloud.size()));
    EXPECT_TRUE(raw.plane_axes.empty());
    EXPECT_TRUE(raw.has_neighbor_lists(cloud.size()));
}

TEST(Normals, RegularizePlaneCovariance) {
    Eigen::Matrix3d C = Eigen::Vector3d(4.0, 0.01, 2.0).asDiagonal();
    const Eigen::Matrix3d R = regularize_plane_covariance(C, 1e-3);
    EXPECT_TRUE(R.isApprox(Eigen::Vector3d(1.0, 1e-3, 1.0).asDiagonal().toDenseMatrix(), 1e-12));
}

}  // namespace
}  // namespace lidarfuse::core
