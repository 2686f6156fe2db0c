#include "core/preprocess/voxel_grid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <tuple>

namespace lidarfuse::core {
namespace {

using Key = std::tuple<long, long, long>;

Key key_of(const Eigen::Vector3d& p, double size) {
    return {static_cast<long>(std::floor(p.x() / size)),
            static_cast<long>(std::floor(p.y() / size)),
            static_cast<long>(std::floor(p.z() / size))};
}

// n points uniform in a slab: x and y in [-half, half] m, z in a fifth of that.
std::vector<Eigen::Vector3d> random_slab(unsigned seed, std::size_t n, double half) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-half, half);
    std::vector<Eigen::Vector3d> pts(n);
    for (auto& p : pts) p = Eigen::Vector3d(u(rng), u(rng), 0.2 * u(rng));
    return pts;
}

TEST(VoxelGrid, CentroidsMatchABruteForceReference) {
    const std::vector<Eigen::Vector3d> pts = random_slab(1, 20000, 20.0);
    const double size = 1.3;
    std::map<Key, std::pair<Eigen::Vector3d, int>> ref;
    for (const auto& p : pts) {
        auto& e = ref.try_emplace(key_of(p, size), Eigen::Vector3d::Zero(), 0).first->second;
        e.first += p;
        ++e.second;
    }
    VoxelGrid grid;
    PointCloud out;
    VoxelIndexMap map;
    const VoxelGridStats stats = grid.downsample(pts, {size, 1}, &out, &map);
    ASSERT_EQ(out.size(), ref.size());
    EXPECT_EQ(stats.num_output, ref.size());
    EXPECT_EQ(stats.num_invalid, 0u);
    for (std::size_t v = 0; v < out.size(); ++v) {
        // Every centroid is the mean of its voxel's points, and the index map lists exactly
        // those points.
        ASSERT_LT(map.offsets[v], map.offsets[v + 1]);
        const Key k = key_of(pts[map.point_indices[map.offsets[v]]], size);
        const auto& e = ref.at(k);
        EXPECT_LT((out.points[v] - e.first / e.second).norm(), 1e-12);
        EXPECT_EQ(static_cast<int>(map.offsets[v + 1] - map.offsets[v]), e.second);
        for (std::uint32_t j = map.offsets[v]; j < map.offsets[v + 1]; ++j) {
            EXPECT_EQ(key_of(pts[map.point_indices[j]], size), k);
            EXPECT_EQ(map.voxel_of_point[map.point_indices[j]], v);
        }
    }
    EXPECT_EQ(map.offsets.back(), pts.size());
}

TEST(VoxelGrid, NegativeCoordinatesFloorCorrectly) {
    // -0.1 and 0.1 are in different 1 m voxels (floor, not truncation).
    const std::vector<Eigen::Vector3d> pts = {{-0.1, 0.5, 0.5}, {0.1, 0.5, 0.5}, {0.9, 0.5, 0.5}};
    const PointCloud out = voxel_downsample(pts, {1.0, 1});
    ASSERT_EQ(out.size(), 2u);
    EXPECT_TRUE(out.points[0].isApprox(Eigen::Vector3d(-0.1, 0.5, 0.5)));
    EXPECT_TRUE(out.points[1].isApprox(Eigen::Vector3d(0.5, 0.5, 0.5)));
}

TEST(VoxelGrid, MinPointsInvalidPointsAndReuse) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::vector<Eigen::Vector3d> pts = {{0.1, 0.1, 0.1}, {0.2, 0.2, 0.2}, {0.3, 0.1, 0.2},
                                        {5.5, 5.5, 5.5}, {nan, 0, 0},     {1e30, 0, 0}};
    VoxelGrid grid;
    PointCloud out;
    VoxelIndexMap map;
    VoxelGridStats s = grid.downsample(pts, {1.0, 2}, &out, &map);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_TRUE(out.points[0].isApprox(Eigen::Vector3d(0.2, 0.4 / 3, 0.5 / 3)));
    EXPECT_EQ(s.num_invalid, 2u);
    EXPECT_EQ(s.num_dropped_sparse, 1u);
    EXPECT_EQ(map.voxel_of_point[3], VoxelIndexMap::kNoVoxel);
    EXPECT_EQ(map.voxel_of_point[4], VoxelIndexMap::kNoVoxel);
    EXPECT_EQ(map.voxel_of_point[0], 0u);
    // Reuse with a different input and voxel size: no stale state.
    s = grid.downsample({{0, 0, 0}, {3, 3, 3}}, {0.5, 1}, &out, &map);
    EXPECT_EQ(out.size(), 2u);
    EXPECT_EQ(map.voxel_of_point.size(), 2u);
    // Empty input and an invalid voxel size.
    EXPECT_EQ(grid.downsample({}, {1.0, 1}, &out).num_output, 0u);
    EXPECT_TRUE(out.empty());
    EXPECT_EQ(grid.downsample(pts, {0.0, 1}, &out).num_output, 0u);
}

TEST(VoxelGrid, OutputOrderIsFirstAppearance) {
    const std::vector<Eigen::Vector3d> pts = {{5, 0, 0}, {1, 0, 0}, {5.2, 0, 0}, {-3, 0, 0}};
    const PointCloud out = voxel_downsample(pts, {1.0, 1});
    ASSERT_EQ(out.size(), 3u);
    EXPECT_NEAR(out.points[0].x(), 5.1, 1e-12);
    EXPECT_NEAR(out.points[1].x(), 1.0, 1e-12);
    EXPECT_NEAR(out.points[2].x(), -3.0, 1e-12);
}

// The Morton code of a point's voxel, bit by bit: bit i of its x, y, z coordinates relative
// to `low` (the lowest voxel coordinates of the cloud) goes to bit 3 i + 2, 3 i + 1, 3 i.
std::uint64_t morton_reference(const Eigen::Vector3d& p, double size, const Key& low) {
    const auto [x, y, z] = key_of(p, size);
    const long axes[3] = {z - std::get<2>(low), y - std::get<1>(low), x - std::get<0>(low)};
    std::uint64_t code = 0;
    for (int a = 0; a < 3; ++a) {
        const auto v = static_cast<std::uint64_t>(axes[a]);
        for (int i = 0; i < 21; ++i) code |= ((v >> i) & 1u) << (3 * i + a);
    }
    return code;
}

class VoxelGridOrder : public ::testing::TestWithParam<bool> {};

// In Morton order the output holds the same centroids, each voxel's points still listed
// against it, sorted by their voxels' codes.
TEST(VoxelGrid, SpatialOrderIsMortonOrderOfTheSameCentroids) {
    const std::vector<Eigen::Vector3d> pts = random_slab(2, 8000, 20.0);
    const double size = 0.7;
    VoxelGrid grid;
    PointCloud plain, spatial;
    VoxelIndexMap map;
    grid.downsample(pts, {size, 1}, &plain);
    grid.downsample(pts, {size, 1, true}, &spatial, &map);
    ASSERT_EQ(spatial.size(), plain.size());
    std::map<Key, Eigen::Vector3d> by_key;
    Key low{1L << 20, 1L << 20, 1L << 20};
    for (const auto& p : plain.points) {
        const Key k = key_of(p, size);
        by_key.emplace(k, p);
        low = {std::min(std::get<0>(low), std::get<0>(k)),
               std::min(std::get<1>(low), std::get<1>(k)),
               std::min(std::get<2>(low), std::get<2>(k))};
    }
    for (std::size_t v = 0; v < spatial.size(); ++v) {
        EXPECT_EQ(by_key.at(key_of(spatial.points[v], size)), spatial.points[v]);
        if (v > 0) {
            EXPECT_LT(morton_reference(spatial.points[v - 1], size, low),
                      morton_reference(spatial.points[v], size, low));
        }
        for (std::uint32_t j = map.offsets[v]; j < map.offsets[v + 1]; ++j) {
            EXPECT_EQ(key_of(pts[map.point_indices[j]], size), key_of(spatial.points[v], size));
            EXPECT_EQ(map.voxel_of_point[map.point_indices[j]], v);
        }
    }
    EXPECT_EQ(map.offsets.back(), pts.size());
}

// A point's twin is the previous call's point from the same voxel: on a scene that moves
// by less than a voxel most voxels have one, and each names the right previous point, in
// either output order.
TEST_P(VoxelGridOrder, TwinsNameThePreviousCallsPointOfTheSameVoxel) {
    const bool spatial = GetParam();
    const std::vector<Eigen::Vector3d> before = random_slab(3, 5000, 20.0);
    std::vector<Eigen::Vector3d> after;
    for (const auto& p : before) after.push_back(p + Eigen::Vector3d(0.01, -0.02, 0.0));
    after.push_back({500.0, 500.0, 0.0});  // a voxel the first call did not have
    const double size = 1.0;
    VoxelGrid grid;
    PointCloud first, second;
    std::vector<std::uint32_t> twins;
    grid.downsample(before, {size, 1, spatial}, &first, nullptr, &twins);
    EXPECT_TRUE(std::all_of(twins.begin(), twins.end(),
                            [](std::uint32_t t) { return t == VoxelIndexMap::kNoVoxel; }));
    grid.downsample(after, {size, 1, spatial}, &second, nullptr, &twins);
    ASSERT_EQ(twins.size(), second.size());
    std::size_t with_twin = 0;
    for (std::size_t i = 0; i < second.size(); ++i) {
        if (twins[i] == VoxelIndexMap::kNoVoxel) {
            for (const auto& p : first.points)
                EXPECT_NE(key_of(p, size), key_of(second.points[i], size));
            continue;
        }
        ++with_twin;
        ASSERT_LT(twins[i], first.size());
        EXPECT_EQ(key_of(first.points[twins[i]], size), key_of(second.points[i], size));
    }
    EXPECT_GT(with_twin, second.size() * 8 / 10);
    // Another voxel size: no twins.
    grid.downsample(after, {2.0 * size, 1, spatial}, &first, nullptr, &twins);
    EXPECT_TRUE(std::all_of(twins.begin(), twins.end(),
                            [](std::uint32_t t) { return t == VoxelIndexMap::kNoVoxel; }));
}

INSTANTIATE_TEST_SUITE_P(FirstAppearanceAndMorton, VoxelGridOrder, ::testing::Bool());

// The table starts sized for the previous call's voxels: a call with many more voxels
// grows it, and must still give one centroid per voxel, as a brute-force grouping does,
// and the right twins.
TEST(VoxelGrid, ATableSizedForFewerVoxelsGrowsAndGivesTheSameCloud) {
    const std::vector<Eigen::Vector3d> few = random_slab(5, 50, 15.0);
    const std::vector<Eigen::Vector3d> many = random_slab(6, 20000, 15.0);  // ~4 per voxel
    std::map<Key, std::pair<Eigen::Vector3d, int>> ref;
    for (const auto& p : many) {
        auto& e = ref.try_emplace(key_of(p, 1.0), Eigen::Vector3d::Zero(), 0).first->second;
        e.first += p;
        ++e.second;
    }
    VoxelGrid grid;
    PointCloud small, grown;
    std::vector<std::uint32_t> twins;
    for (int round = 0; round < 2; ++round) {  // the second after a grown table shrank
        grid.downsample(few, {1.0, 1}, &small);
        grid.downsample(many, {1.0, 1}, &grown, nullptr, &twins);
        ASSERT_GT(ref.size(), 4 * (small.size() + 64));  // beyond the first table's share
        ASSERT_EQ(grown.size(), ref.size());
        std::size_t with_twin = 0;
        for (std::size_t i = 0; i < grown.size(); ++i) {
            const auto it = ref.find(key_of(grown.points[i], 1.0));
            ASSERT_NE(it, ref.end());
            EXPECT_TRUE(grown.points[i].isApprox(it->second.first / it->second.second, 1e-12));
            if (twins[i] == VoxelIndexMap::kNoVoxel) continue;
            ++with_twin;
            ASSERT_LT(twins[i], small.size());
            EXPECT_EQ(key_of(small.points[twins[i]], 1.0), it->first);
        }
        EXPECT_GT(with_twin, 0u);
    }
}

}  // namespace
}  // namespace lidarfuse::core
