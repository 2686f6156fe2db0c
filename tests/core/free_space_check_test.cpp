#include "core/free_space_check.hpp"

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
            case 0: points.emplace_back(-20.0, -15.0 + 30.0 * a, -3.0 + 10.0 * b); break;
            case 1: points.emplace_back(20.0, -15.0 + 30.0 * a, -3.0 + 10.0 * b); break;
            case 2: points.emplace_back(-20.0 + 40.0 * a, -15.0, -3.0 + 10.0 * b); break;
            case 3: points.emplace_back(-20.0 + 40.0 * a, 15.0, -3.0 + 10.0 * b); break;
            case 4: points.emplace_back(-20.0 + 40.0 * a, -15.0 + 30.0 * b, -3.0); break;
            default: points.emplace_back(8.0 + 2.0 * a, 4.0, -3.0 + 10.0 * b); break;  // pillar face
        }
    }
    return points;
}

// The room's points in the frame of a sensor at T_world_sensor (no occlusion: every
// point is a real surface point, so the true transform can violate nothing).
std::vector<Eigen::Vector3d> view(const std::vector<Eigen::Vector3d>& world, const Eigen::Isometry3d& T_world_sensor) {
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
    const FreeSpaceResult r = free_space_violations(a, {}, Eigen::Isometry3d::Identity());
    EXPECT_EQ(r.num_tested, 0u);
    EXPECT_EQ(r.violation_share, 0.0);
    const FreeSpaceResult nan_input =
        free_space_violations({Eigen::Vector3d(NAN, 0, 0), Eigen::Vector3d::Zero()}, a, Eigen::Isometry3d::Identity());
    EXPECT_EQ(nan_input.num_tested, 0u);
}

}  // namespace
}  // namespace lidarfuse::core
