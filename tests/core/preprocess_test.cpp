#include "core/preprocess/preprocess.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

namespace lidarfuse::core {
namespace {

TEST(Preprocess, RangeFilterDropsInvalidAndOutOfRange) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    PointCloud in;
    in.points = {{0, 0, 0},   {1, 0, 0},   {nan, 1, 1}, {0, 250, 0},
                 {0, 0.3, 0}, {inf, 0, 0}, {3, 4, 0}};
    in.normals.assign(in.points.size(), Eigen::Vector3d::UnitZ());
    in.normals[6] = Eigen::Vector3d::UnitX();
    PointCloud out;
    std::vector<std::uint32_t> kept;
    EXPECT_EQ(filter_range(in, {0.5, 200.0, Eigen::Vector3d::Zero()}, &out, &kept), 2u);
    EXPECT_EQ(kept, (std::vector<std::uint32_t>{1, 6}));
    ASSERT_TRUE(out.has_normals());
    EXPECT_TRUE(out.normals[1].isApprox(Eigen::Vector3d::UnitX()));
    // Range is measured from the given origin.
    RangeFilterParams shifted{0.5, 2.0, Eigen::Vector3d(3, 4, 0)};
    EXPECT_EQ(filter_range(in, shifted, &out, &kept), 0u);  // (3,4,0) itself is at range 0
    shifted.min_range_m = 0.0;
    EXPECT_EQ(filter_range(in, shifted, &out, &kept), 1u);
    EXPECT_EQ(kept.front(), 6u);
}

TEST(Preprocess, StatisticalOutlierRemovalDropsIsolatedPoints) {
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> u(0.0, 10.0);
    PointCloud in;
    for (int i = 0; i < 5000; ++i) in.points.emplace_back(u(rng), u(rng), 0.0);  // dense plane
    const std::vector<Eigen::Vector3d> outliers = {{5, 5, 8}, {-20, 3, 1}, {15, 15, 15}};
    for (const auto& p : outliers) in.points.push_back(p);
    PointCloud out;
    std::vector<std::uint32_t> kept;
    StatisticalOutlierParams params;
    remove_statistical_outliers(in, params, &out, &kept, 2);
    for (std::size_t o = 0; o < outliers.size(); ++o) {
        EXPECT_EQ(std::count(kept.begin(), kept.end(), 5000 + o), 0) << "outlier " << o;
    }
    // Almost all plane points stay (only border points can exceed 2 sigma).
    EXPECT_GT(out.size(), 4800u);
    // Tiny input: kept as is.
    PointCloud tiny;
    tiny.points = {{0, 0, 0}, {100, 0, 0}};
    EXPECT_EQ(remove_statistical_outliers(tiny, params, &out), 2u);
}

TEST(Preprocess, RadiusOutlierRemoval) {
    PointCloud in;
    // A 5x5 grid at 0.1 m spacing plus a lone point 3 m away.
    for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j) in.points.emplace_back(0.1 * i, 0.1 * j, 0);
    in.points.emplace_back(3, 0, 0);
    PointCloud out;
    std::vector<std::uint32_t> kept;
    RadiusOutlierParams params;
    params.radius_m = 0.15;
    params.min_neighbors = 3;  // corners have 3 (2 at 0.1, 1 at 0.141)
    EXPECT_EQ(remove_radius_outliers(in, params, &out, &kept), 25u);
    EXPECT_EQ(std::count(kept.begin(), kept.end(), 25u), 0);
    params.min_neighbors = 4;  // corners drop out
    EXPECT_EQ(remove_radius_outliers(in, params, &out, &kept), 21u);
    PointCloud empty;
    EXPECT_EQ(remove_radius_outliers(empty, params, &out), 0u);
}

TEST(Preprocess, ExtractIndicesCarriesAttributes) {
    PointCloud in;
    in.points = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
    in.covariances = {Eigen::Matrix3d::Identity(), 2 * Eigen::Matrix3d::Identity(),
                      3 * Eigen::Matrix3d::Identity()};
    PointCloud out;
    extract_indices(in, {2, 0}, &out);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_TRUE(out.has_covariances());
    EXPECT_FALSE(out.has_normals());
    EXPECT_EQ(out.covariances[0](0, 0), 3.0);
    EXPECT_EQ(out.points[1], Eigen::Vector3d::Zero());
}

}  // namespace
}  // namespace lidarfuse::core
