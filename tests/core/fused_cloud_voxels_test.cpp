#include "core/pipeline/fused_cloud_voxels.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <tuple>

namespace lidarfuse::core {
namespace {

// The reference: a std::map keyed by floor(p / size) and the dynamic flag.
using VoxelId = std::tuple<long, long, long, int>;
struct Expected {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double intensity = 0.0;
    int count = 0;
    std::uint8_t sensor = 0;
    std::size_t first = 0;  // index of the voxel's first point
};

std::map<VoxelId, Expected> reference(const FusedCloud& in, double size) {
    std::map<VoxelId, Expected> out;
    for (std::size_t i = 0; i < in.points.size(); ++i) {
        const Eigen::Vector3d p = in.points[i].cast<double>();
        if (!p.allFinite()) continue;
        const VoxelId id{static_cast<long>(std::floor(p.x() / size)),
                         static_cast<long>(std::floor(p.y() / size)),
                         static_cast<long>(std::floor(p.z() / size)), in.dynamic[i]};
        auto [it, fresh] = out.try_emplace(id);
        if (fresh) {
            it->second.sensor = in.sensor[i];
            it->second.first = i;
        }
        it->second.sum += p;
        it->second.intensity += in.intensity[i];
        ++it->second.count;
    }
    return out;
}

FusedCloud random_cloud(std::uint32_t seed, std::size_t n) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-15.0f, 15.0f);
    std::uniform_int_distribution<int> sensor(0, 3);
    FusedCloud c;
    for (std::size_t i = 0; i < n; ++i) {
        c.points.emplace_back(u(rng), u(rng), 0.1f * u(rng));
        c.intensity.push_back(std::abs(u(rng)) * 10.0f);
        c.sensor.push_back(static_cast<std::uint8_t>(sensor(rng)));
        c.dynamic.push_back(i % 7 == 0);
    }
    return c;
}

void expect_matches_reference(const FusedCloud& in, double size, const FusedCloud& out) {
    const auto ref = reference(in, size);
    ASSERT_EQ(out.points.size(), ref.size());
    ASSERT_EQ(out.intensity.size(), ref.size());
    ASSERT_EQ(out.sensor.size(), ref.size());
    ASSERT_EQ(out.dynamic.size(), ref.size());
    // Output order is the order of each voxel's first point.
    std::map<std::size_t, const Expected*> by_first;
    for (const auto& [id, e] : ref) by_first[e.first] = &e;
    std::size_t v = 0;
    for (const auto& [first, e] : by_first) {
        const Eigen::Vector3d centroid = e->sum / e->count;
        EXPECT_LT((out.points[v].cast<double>() - centroid).norm(), 1e-5) << "voxel " << v;
        EXPECT_NEAR(out.intensity[v], e->intensity / e->count, 1e-3) << "voxel " << v;
        EXPECT_EQ(out.sensor[v], e->sensor) << "voxel " << v;
        EXPECT_EQ(out.dynamic[v], in.dynamic[first]) << "voxel " << v;
        ++v;
    }
}

TEST(FusedCloudVoxels, MatchesABruteForceReferenceInFirstPointOrder) {
    const FusedCloud in = random_cloud(1, 30000);
    FusedCloudVoxels voxels;
    FusedCloud out;
    voxels.downsample(in, 0.7, &out);
    expect_matches_reference(in, 0.7, out);
    EXPECT_LT(out.points.size(), in.points.size());
}

TEST(FusedCloudVoxels, KeepsStaticAndDynamicPointsOfOneVoxelApart) {
    FusedCloud in;
    in.points = {{0.1f, 0.1f, 0.1f}, {0.3f, 0.3f, 0.3f}, {0.2f, 0.2f, 0.2f}, {0.4f, 0.4f, 0.4f}};
    in.intensity = {1.0f, 3.0f, 10.0f, 20.0f};
    in.sensor = {2, 1, 3, 0};
    in.dynamic = {0, 0, 1, 1};
    FusedCloudVoxels voxels;
    FusedCloud out;
    voxels.downsample(in, 1.0, &out);
    ASSERT_EQ(out.points.size(), 2u);
    EXPECT_EQ(out.dynamic[0], 0);
    EXPECT_EQ(out.dynamic[1], 1);
    EXPECT_TRUE(out.points[0].isApprox(Eigen::Vector3f(0.2f, 0.2f, 0.2f)));
    EXPECT_TRUE(out.points[1].isApprox(Eigen::Vector3f(0.3f, 0.3f, 0.3f)));
    EXPECT_FLOAT_EQ(out.intensity[0], 2.0f);
    EXPECT_FLOAT_EQ(out.intensity[1], 15.0f);
    EXPECT_EQ(out.sensor[0], 2);  // the first point's sensor
    EXPECT_EQ(out.sensor[1], 3);
}

TEST(FusedCloudVoxels, LeavesOutPointsThatAreNotFiniteOrBeyondTheGrid) {
    FusedCloud in = random_cloud(2, 100);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    in.points[3] = {nan, 0.0f, 0.0f};
    in.points[4] = {0.0f, std::numeric_limits<float>::infinity(), 0.0f};
    in.points[5] = {3e30f, 0.0f, 0.0f};  // 2^20 voxels is about 1e5 m at 0.1 m
    FusedCloudVoxels voxels;
    FusedCloud out;
    voxels.downsample(in, 0.1, &out);
    for (const auto& p : out.points) EXPECT_TRUE(p.allFinite() && p.norm() < 100.0f);
    FusedCloud kept = in;
    kept.points[5] = {nan, 0.0f, 0.0f};  // the reference skips only non-finite points
    expect_matches_reference(kept, 0.1, out);
}

TEST(FusedCloudVoxels, EmptyInputOrNoVoxelSizeGiveAnEmptyCloud) {
    FusedCloudVoxels voxels;
    FusedCloud out = random_cloud(3, 10);
    voxels.downsample(FusedCloud{}, 0.5, &out);
    EXPECT_TRUE(out.points.empty() && out.sensor.empty() && out.dynamic.empty());
    const FusedCloud in = random_cloud(3, 10);
    for (double size : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()}) {
        voxels.downsample(in, size, &out);
        EXPECT_TRUE(out.points.empty()) << size;
    }
}

TEST(FusedCloudVoxels, ALaterCallKeepsNothingOfAnEarlierOne) {
    FusedCloudVoxels voxels;
    FusedCloud out;
    voxels.downsample(random_cloud(4, 50000), 0.2, &out);
    const FusedCloud small = random_cloud(5, 500);
    voxels.downsample(small, 1.5, &out);
    expect_matches_reference(small, 1.5, out);
}

}  // namespace
}  // namespace lidarfuse::core
