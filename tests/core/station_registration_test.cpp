// A road segment's stations registered to each other from nothing (issue 20,
// core/initial/station_registration.hpp, road_grid_search.hpp), on synthetic road scenes
// whose truth is exact: each station's cloud is what stands within its reach, in its own
// road frame (the road at z = 0). The right placement is found where the stations share
// enough; a road that repeats itself, or stations that share nothing, are refused, never
// guessed.
#include "core/initial/station_registration.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/common/angles.hpp"
#include "core/common/se3.hpp"

namespace lidarfuse::core {
namespace {

// A vertical rectangle from (x0, y0) to (x1, y1), 0..height m above the road, sampled every
// 0.4 m.
void add_wall(double x0, double y0, double x1, double y1, double height,
              std::vector<Eigen::Vector3d>* world) {
    const double length = std::hypot(x1 - x0, y1 - y0);
    for (double s = 0; s <= length; s += 0.4) {
        for (double z = 0.2; z <= height; z += 0.4) {
            world->emplace_back(x0 + (x1 - x0) * s / length, y0 + (y1 - y0) * s / length, z);
        }
    }
}

// A straight road along x: the road surface, and on each side what `add_sides` puts there.
struct RoadScene {
    std::vector<Eigen::Vector3d> structure;  // world frame, m
    double road_half_width_m = 12.0;
};

// Buildings of random length and depth along both sides, and poles every `pole_spacing_m`
// (jittered by up to `pole_jitter_m`).
RoadScene street(unsigned seed, bool buildings, double pole_spacing_m, double pole_jitter_m) {
    RoadScene scene;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (const double side : {-1.0, 1.0}) {
        for (double x = -250; buildings && x < 250;) {
            const double length = 8 + 20 * u(rng), setback = 14 + 10 * u(rng);
            add_wall(x, side * setback, x + length, side * setback, 4 + 8 * u(rng),
                     &scene.structure);
            add_wall(x, side * setback, x, side * (setback + 10), 6, &scene.structure);
            x += length + 3 + 12 * u(rng);
        }
        for (double x = -250; x < 250; x += pole_spacing_m) {
            const double px = x + pole_jitter_m * (2 * u(rng) - 1);
            add_wall(px, side * 10.0, px + 0.3, side * 10.0, 6, &scene.structure);
        }
    }
    return scene;
}

// A road frame at (x, y) of the world, turned by `yaw_deg` about its up axis.
Eigen::Isometry3d road_frame(double x, double y, double yaw_deg) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translate(Eigen::Vector3d(x, y, 0.0))
        .rotate(Eigen::AngleAxisd(yaw_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()));
    return T;
}

// What a station at T_world_station sees within `reach_m`: the structure and the road (free
// ground every 0.5 m where no structure stands), in its road frame, with 2 cm of noise.
PointCloud station_cloud(const RoadScene& scene, const Eigen::Isometry3d& T_world_station,
                         double reach_m, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.02);
    const Eigen::Vector2d at = T_world_station.translation().head<2>();
    const Eigen::Isometry3d T_station_world = T_world_station.inverse();
    PointCloud cloud;
    const auto add = [&](const Eigen::Vector3d& p) {
        if ((p.head<2>() - at).norm() > reach_m) return;
        cloud.points.push_back(T_station_world * p +
                               Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    };
    for (const auto& p : scene.structure) add(p);
    for (double x = at.x() - reach_m; x <= at.x() + reach_m; x += 0.5) {
        for (double y = -scene.road_half_width_m; y <= scene.road_half_width_m; y += 0.5) {
            add(Eigen::Vector3d(x, y, 0.0));
        }
    }
    return cloud;
}

InitialRegistrationParams station_params() {
    InitialRegistrationParams params = default_initial_registration_params();
    params.method = InitialRegistrationMethod::kStations;
    return params;
}

// Two stations 80 m apart, the second turned by 143 deg: placed within 3 cm / 0.05 deg of
// the truth (the bound for the segment), the grid's placement within a fine cell.
TEST(StationRegistration, TwoStationsOfAStreetArePlacedFromNothing) {
    const RoadScene scene = street(7, true, 25.0, 4.0);
    const Eigen::Isometry3d T0 = road_frame(-40, -3, 0), T1 = road_frame(40, 4, 143);
    const std::vector<PointCloud> clouds = {station_cloud(scene, T0, 70, 1),
                                            station_cloud(scene, T1, 70, 2)};
    const Eigen::Isometry3d truth = T0.inverse() * T1;

    const RoadGridPlacement grid = search_road_grid(clouds[0].points, clouds[1].points, {}, 2);
    ASSERT_TRUE(grid.found) << grid.why;
    EXPECT_LT(translation_error_m(grid.T_target_source, truth), 0.75);
    EXPECT_LT(rotation_error_deg(grid.T_target_source, truth), 0.5);
    EXPECT_LT(grid.rival_score, 0.5 * grid.score);

    const InitialRegistrationResult result = register_initial(clouds, station_params(), 2);
    ASSERT_TRUE(result.sensors[0].registered);
    ASSERT_TRUE(result.sensors[1].registered) << to_string(result.sensors[1].status);
    EXPECT_LT(translation_error_m(result.sensors[1].T_root_sensor, truth), 0.03);
    EXPECT_LT(rotation_error_deg(result.sensors[1].T_root_sensor, truth), 0.05);
    EXPECT_TRUE(result.sensors[1].ground.found);  // its road plane: z = 0 of its frame
}

// Poles every 20 m on a road with nothing else: every shift by 20 m along it fits as well.
// Refused as ambiguous, not guessed.
TEST(StationRegistration, ARoadThatRepeatsItselfIsRefusedAsAmbiguous) {
    const RoadScene scene = street(3, false, 20.0, 0.0);
    const std::vector<PointCloud> clouds = {station_cloud(scene, road_frame(-40, 0, 0), 70, 1),
                                            station_cloud(scene, road_frame(40, 0, 30), 70, 2)};
    const RoadGridPlacement grid = search_road_grid(clouds[0].points, clouds[1].points, {}, 2);
    EXPECT_FALSE(grid.found);
    EXPECT_NE(grid.why.find("ambiguous"), std::string::npos) << grid.why;
    const InitialRegistrationResult result = register_initial(clouds, station_params(), 2);
    EXPECT_FALSE(result.sensors[1].registered);
    EXPECT_EQ(result.sensors[1].status, SensorRegistrationStatus::kAmbiguous);
}

// Stations 400 m apart see different streets: nothing in common, nothing placed.
TEST(StationRegistration, StationsThatShareNothingAreNotPlaced) {
    const RoadScene scene = street(11, true, 25.0, 4.0);
    const std::vector<PointCloud> clouds = {station_cloud(scene, road_frame(-200, 0, 0), 45, 1),
                                            station_cloud(scene, road_frame(200, 0, 60), 45, 2)};
    const InitialRegistrationResult result = register_initial(clouds, station_params(), 2);
    EXPECT_TRUE(result.sensors[0].registered);
    EXPECT_FALSE(result.sensors[1].registered);
    EXPECT_NE(result.sensors[1].status, SensorRegistrationStatus::kRegistered);
}

}  // namespace
}  // namespace lidarfuse::core
