#include "core/registration/free_space_check.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace lidarfuse::core {
namespace {

// A box room 40 x 30 x 10 m around the origin, sampled on its walls, floor and ceiling,
// plus a pillar that makes the room asymmetric.
std::vector<Eigen::Vector3d> room(std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i < 20000; ++i) {
        const double a = u(rng), b = u(rng);
        switch (i % 6) {
            case 0:
                points.emplace_back(-20.0, -15.0 + 30.0 * a, -3.0 + 10.0 * b);
                break;
            case 1:
                points.emplace_back(20.0, -15.0 + 30.0 * a, -3.0 + 10.0 * b);
                break;
            case 2:
                points.emplace_back(-20.0 + 40.0 * a, -15.0, -3.0 + 10.0 * b);
                break;
            case 3:
                points.emplace_back(-20.0 + 40.0 * a, 15.0, -3.0 + 10.0 * b);
                break;
            case 4:
                points.emplace_back(-20.0 + 40.0 * a, -15.0 + 30.0 * b, -3.0);
                break;
            default:
                points.emplace_back(8.0 + 2.0 * a, 4.0, -3.0 + 10.0 * b);
                break;  // pillar face
        }
    }
    return points;
}

// The room's points in the frame of a sensor at T_world_sensor (no occlusion: every
// point is a real surface point, so the true transform can violate nothing).
std::vector<Eigen::Vector3d> view(const std::vector<Eigen::Vector3d>& world,
                                  const Eigen::Isometry3d& T_world_sensor) {
    std::vector<Eigen::Vector3d> out;
    const Eigen::Isometry3d T_sensor_world = T_world_sensor.inverse();
    for (const auto& p : world) out.push_back(T_sensor_world * p);
    return out;
}

TEST(FreeSpaceCheck, TrueTransformHasNoViolations) {
    const auto world = room(1);
    Eigen::Isometry3d T_world_a = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_world_b = Eigen::Isometry3d::Identity();
    T_world_b.translation() = Eigen::Vector3d(5.0, -3.0, 0.5);
    T_world_b.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const auto a = view(world, T_world_a);
    const auto b = view(world, T_world_b);
    const Eigen::Isometry3d T_a_b = T_world_a.inverse() * T_world_b;
    const FreeSpaceResult r = free_space_violations_both(b, a, T_a_b);
    EXPECT_GT(r.num_tested, 1000u);
    EXPECT_LT(r.violation_share, 0.01);
}

TEST(FreeSpaceCheck, ShiftedTransformPutsPointsIntoFreeSpace) {
    const auto world = room(2);
    Eigen::Isometry3d T_world_b = Eigen::Isometry3d::Identity();
    T_world_b.translation() = Eigen::Vector3d(5.0, -3.0, 0.5);
    const auto a = view(world, Eigen::Isometry3d::Identity());
    const auto b = view(world, T_world_b);
    // Wrong by 6 m: b's far wall lands inside a's room.
    Eigen::Isometry3d T_wrong = T_world_b;
    T_wrong.translation().x() -= 6.0;
    const FreeSpaceResult r = free_space_violations_both(b, a, T_wrong);
    EXPECT_GT(r.violation_share, 0.1);
    EXPECT_GT(r.num_violations, 100u);
}

TEST(FreeSpaceCheck, NoReturnsMeansNothingTested) {
    const auto a = room(3);
    const FreeSpaceResult r =
        free_space_violations(a, std::vector<Eigen::Vector3d>{}, Eigen::Isometry3d::Identity());
    EXPECT_EQ(r.num_tested, 0u);
    EXPECT_EQ(r.violation_share, 0.0);
    const FreeSpaceResult nan_input = free_space_violations(
        {Eigen::Vector3d(NAN, 0, 0), Eigen::Vector3d::Zero()}, a, Eigen::Isometry3d::Identity());
    EXPECT_EQ(nan_input.num_tested, 0u);
}

// A flat road `height_m` below a sensor, sampled along four rings of beams 1 deg apart,
// each at the top of its 1-deg elevation bin (`top_deg`, top_deg - 1, ...), and points of
// the same road 0.8 deg steeper, in the same bins: along the sensor's rays they lie up to
// metres in front of its returns (the road's range changes by r^2 / h per radian at a
// grazing angle), although they are the same road.
struct GrazingRoad {
    std::vector<Eigen::Vector3d> rings;         // the sensor's returns
    std::vector<Eigen::Vector3d> ring_normals;  // the road's normal at each
    std::vector<Eigen::Vector3d> between;       // road points between the rings
};

Eigen::Vector3d on_road(double height_m, double elevation_deg, double azimuth_deg) {
    const double e = elevation_deg * M_PI / 180.0, a = azimuth_deg * M_PI / 180.0;
    const double r = height_m / std::sin(-e);
    return {r * std::cos(e) * std::cos(a), r * std::cos(e) * std::sin(a), r * std::sin(e)};
}

GrazingRoad grazing_road(double height_m, double top_deg) {
    GrazingRoad road;
    for (int ring = 0; ring < 4; ++ring) {
        for (double azimuth_deg = -30.0; azimuth_deg <= 30.0; azimuth_deg += 0.2) {
            road.rings.push_back(on_road(height_m, top_deg - ring, azimuth_deg));
            road.ring_normals.emplace_back(0.0, 0.0, 1.0);
            road.between.push_back(on_road(height_m, top_deg - ring - 0.8, azimuth_deg));
        }
    }
    return road;
}

// 6 m up a pole, rings 10.1-13.1 deg below the horizon: the road is met 76.9-79.9 deg from
// its normal, below max_incidence_deg (80).
TEST(FreeSpaceCheck, GrazingRoadBetweenBeamsIsNoViolationWithItsNormals) {
    const GrazingRoad road = grazing_road(6.0, -10.1);
    const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
    // Without normals the bin's first return bounds the road points between the rings by
    // range alone: they count as violations.
    const FreeSpaceResult points_only =
        free_space_violations(road.between, FreeSpaceMap(road.rings, {}), I);
    EXPECT_GT(points_only.num_tested, 1000u);
    EXPECT_GT(points_only.violation_share, 0.5);
    // With the road's normal the range may change across the bin by r * bin * tan(incidence).
    const FreeSpaceResult with_normals =
        free_space_violations(road.between, FreeSpaceMap(road.rings, road.ring_normals), I);
    EXPECT_EQ(with_normals.num_tested, points_only.num_tested);
    EXPECT_EQ(with_normals.num_violations, 0u);
    // A wall 5 m in front of those returns, facing the sensor, is still a violation.
    std::vector<Eigen::Vector3d> wall;
    for (const auto& p : road.rings) wall.push_back(p * (p.norm() - 5.0) / p.norm());
    const FreeSpaceResult blocked =
        free_space_violations(wall, FreeSpaceMap(road.rings, road.ring_normals), I);
    EXPECT_GT(blocked.violation_share, 0.99);
}

// 2 m up (a vehicle's roof), rings 6.1-9.1 deg below the horizon: 80.9-83.9 deg from the
// road's normal, beyond max_incidence_deg: such a return bounds nothing, so its bin tests
// nothing; with the limit raised to 85 deg the slack covers the road between the rings.
TEST(FreeSpaceCheck, ReturnsBeyondTheLargestIncidenceTestNothing) {
    const GrazingRoad road = grazing_road(2.0, -6.1);
    const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
    const FreeSpaceResult points_only =
        free_space_violations(road.between, FreeSpaceMap(road.rings, {}), I);
    EXPECT_GT(points_only.num_tested, 1000u);
    EXPECT_GT(points_only.violation_share, 0.5);
    const FreeSpaceResult with_normals =
        free_space_violations(road.between, FreeSpaceMap(road.rings, road.ring_normals), I);
    EXPECT_EQ(with_normals.num_tested, 0u);
    FreeSpaceParams wider;
    wider.max_incidence_deg = 85.0;
    const FreeSpaceResult tested =
        free_space_violations(road.between, FreeSpaceMap(road.rings, road.ring_normals, wider), I);
    EXPECT_EQ(tested.num_tested, points_only.num_tested);
    EXPECT_EQ(tested.num_violations, 0u);
}

TEST(FreeSpaceCheck, MapFromPointsAloneMatchesThePointOverload) {
    const auto a = room(4);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(3.0, 1.0, 0.0);
    const FreeSpaceResult direct = free_space_violations(a, a, T);
    const FreeSpaceResult mapped = free_space_violations(a, FreeSpaceMap(a, {}), T);
    EXPECT_EQ(direct.num_tested, mapped.num_tested);
    EXPECT_EQ(direct.num_violations, mapped.num_violations);
}

}  // namespace
}  // namespace lidarfuse::core
