#pragma once
// Builders for the parts of a street, shared by the scenarios. A street follows a centre
// line (Path); its cross-section, measured from the centre line (left positive):
//   |o| <= 10.5 m   six 3.5 m lanes, three each way (right-hand traffic), asphalt at z = 0,
//                   painted edge lines, dashed lane lines and a solid centre line
//   10.5 .. 14.5    curb (0.15 m) and sidewalk; cycle track near the curb
//   14.5 .. 17.5    parking strip at z = 0 (parked cars)
//   >= 18.5         buildings
// Ground outside everything: grass 3 mm below the road (so it never coincides with it).

#include <vector>

#include "drivers/sim/mesh.hpp"
#include "drivers/sim/path.hpp"
#include "drivers/sim/rng.hpp"
#include "drivers/sim/scene.hpp"

namespace lidarfuse::sim {

namespace street {
constexpr double kLaneWidthM = 3.5;
constexpr int kLanesPerDirection = 3;
constexpr double kRoadHalfWidthM = kLaneWidthM * kLanesPerDirection;  // 10.5
constexpr double kSidewalkOuterM = 14.5;
constexpr double kCurbHeightM = 0.15;
constexpr double kParkingOuterM = 17.5;
constexpr double kBuildingLineM = 18.5;
constexpr double kGroundZM = -0.003;
}  // namespace street

// Roadside furniture options for one street section.
struct RoadsideParams {
    double building_probability = 0.8;  // chance that a block slot holds a building
    double tree_spacing_m = 18.0;       // mean spacing along each side (0 = no trees)
    double tree_probability = 0.7;
    double lamp_spacing_m = 32.0;
    double sign_spacing_m = 45.0;
    double parked_car_probability = 0.45;
    double buildings_from_m = 0.0;  // arc-length range that gets buildings
    double buildings_to_m = 1e9;
    std::vector<Eigen::Vector2d> keep_out;  // no furniture within 4 m of these (sensor poles)
};

// Position at arc length s shifted sideways by `lateral_m` (left positive), at height z.
Eigen::Vector3d street_point(const Path& centre, double s, double lateral_m, double z_m);

// Road surface with markings for s in [s0, s1].
void add_road_surface(Mesh& mesh, const Path& centre, double s0, double s1);
// Curbs, sidewalks and parking strips on both sides for s in [s0, s1].
void add_sidewalks(Mesh& mesh, const Path& centre, double s0, double s1);
// Buildings, trees, lamps, signs and parked cars on both sides for s in [s0, s1].
void add_roadside(Mesh& mesh, const Path& centre, double s0, double s1,
                  const RoadsideParams& params, CounterRng& rng);
// Ground plane (grass) covering the square |x|, |y| <= half_size_m.
void add_ground(Mesh& mesh, double half_size_m);
// A sensor pole (static; the head's sway is small compared with its distance to others).
void add_sensor_pole(Mesh& mesh, const SensorMount& mount);
// A car body (two boxes) standing on z = z0 at `T_world_car` (x forward).
void add_car(Mesh& mesh, const Eigen::Isometry3d& T_world_car, double length_m, Material m);
// Traffic light mast at (s, right curb) of an approach, arm over the lanes of that
// direction (the right half of the road seen along increasing s).
void add_traffic_light(Mesh& mesh, const Path& centre, double s);

// Lanes, cycle tracks and sidewalks of both directions along [s0, s1] of the centre line.
std::vector<Track> street_tracks(const Path& centre, double s0, double s1);

}  // namespace lidarfuse::sim
