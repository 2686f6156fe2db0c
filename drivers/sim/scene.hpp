#pragma once
// A synthetic roadside scene: static geometry, the tracks traffic moves on, and where the
// sensor poles stand. World frame: metres, z up, road surface at z = 0. Built once per run
// by build_scene(); immutable afterwards and shared read-only by the rendering threads.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "drivers/sim/mesh.hpp"
#include "drivers/sim/path.hpp"

namespace lidarfuse::sim {

enum class Scenario { kCurve, kStraight, kIntersection };
const char* to_string(Scenario scenario);
std::optional<Scenario> scenario_from_string(const std::string& name);

enum class TrackKind : std::uint8_t { kRoadLane, kCyclePath, kSidewalk };

// One traffic track. Road lanes carry cars, trucks and motorcycles, cycle paths bicycles,
// sidewalks pedestrians. Everything on one track moves at the track's speed, so nothing
// overtakes anything (no collision handling needed).
struct Track {
    Path path;
    TrackKind kind = TrackKind::kRoadLane;
    int lane_index = 0;  // road lanes: 0 = inner (fast) .. 2 = outer (trucks)
    double z_m = 0.0;    // surface height (sidewalks are raised)
    double speed_mps = 10.0;
    double mean_headway_s = 4.0;  // mean time between spawns
    // Intersection only: arc-length interval inside the junction box and the signal group
    // (0 or 1) whose green it needs; -1 = no signal.
    int signal_group = -1;
    double conflict_begin_m = 0.0;
    double conflict_end_m = 0.0;
};

// Fixed-time traffic signal plan: group 0 green, all red, group 1 green, all red.
struct SignalPlan {
    double green_s = 14.0;
    double clearance_s = 3.0;
    double cycle_s() const { return 2 * (green_s + clearance_s); }
    // True when group `g` has green for the whole interval [t0_s, t1_s].
    bool green_during(int group, double t0_s, double t1_s) const;
};

// Nominal mounting of one sensor: pole base on the ground, head at pole_height_m, sensor
// yawed towards `aim` and pitched down by tilt_rad about its own y axis.
struct SensorMount {
    Eigen::Vector3d pole_base = Eigen::Vector3d::Zero();
    double pole_height_m = 6.0;
    double yaw_rad = 0.0;
    double tilt_rad = 17.0 * M_PI / 180.0;
};

struct Scene {
    Scenario scenario = Scenario::kStraight;
    Mesh mesh;  // all static geometry
    std::vector<Track> tracks;
    std::vector<SensorMount> mounts;  // one per sensor
    std::optional<SignalPlan> signals;
};

struct SceneParams {
    Scenario scenario = Scenario::kStraight;
    int sensors = 4;         // in all stations together
    std::uint64_t seed = 1;  // places buildings, trees, parked cars
    // Stations along one road (straight and curve only), each with sensors / stations
    // sensors laid out as one station is; their middles station_spacing_m apart along the
    // road, centred on the road's middle. Mounts are station by station.
    int stations = 1;
    double station_spacing_m = 80.0;
};

// Throws std::invalid_argument for sensors outside 1..16, stations that do not divide the
// sensors, several stations at the intersection, or stations beyond the road's ends.
Scene build_scene(const SceneParams& params);

}  // namespace lidarfuse::sim
