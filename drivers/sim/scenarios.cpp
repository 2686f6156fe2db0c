// The three scenes of PAPER.md ("Experiments to reproduce"): curve, straight (zig-zag
// sensors) and a four-arm intersection whose corner buildings block the direct line of
// sight between sensors on neighboring arms.
#include <cmath>
#include <stdexcept>

#include "drivers/sim/scene.hpp"
#include "drivers/sim/street_builder.hpp"

namespace lidarfuse::sim {

namespace {

constexpr double kPoleLateralM = 14.0;  // sensor poles stand at the back of the sidewalk
constexpr double kAimDistanceM = 25.0;  // sensors look at a road point this far away
constexpr double kSceneHalfSizeM = 400.0;
constexpr double kRoadEndMarginM = 20.0;  // no pole closer to a road's end (its view ends there)

double yaw_towards(const Eigen::Vector3d& from, const Eigen::Vector2d& to) {
    return std::atan2(to.y() - from.y(), to.x() - from.x());
}

// Sensor k of n along a street: `side` +1 left / -1 right, at arc length s, looking across
// the road at the centre-line point kAimDistanceM away towards the middle of the station.
SensorMount street_mount(const Path& centre, double s, double side, double s_middle) {
    SensorMount m;
    m.pole_base = street_point(centre, s, side * kPoleLateralM, 0.0);
    const double along = std::sqrt(kAimDistanceM * kAimDistanceM - kPoleLateralM * kPoleLateralM);
    const double s_aim = s > s_middle ? s - along : s + along;
    m.yaw_rad = yaw_towards(m.pole_base, centre.position(s_aim));
    return m;
}

std::vector<Eigen::Vector2d> pole_positions(const std::vector<SensorMount>& mounts) {
    std::vector<Eigen::Vector2d> out;
    for (const auto& m : mounts) out.push_back(m.pole_base.head<2>());
    return out;
}

void finish(Scene& scene) {
    add_ground(scene.mesh, kSceneHalfSizeM);
    for (const auto& m : scene.mounts) add_sensor_pole(scene.mesh, m);
}

// One station's n sensors around arc length s_middle: zig-zag alternates sides 25 m apart,
// otherwise pairs face each other across the road, 40 m apart. Of several stations, none
// may stand beyond the road's ends (one station keeps its layout at any count).
void add_station_mounts(const Path& centre, double s_middle, int n, bool zig_zag,
                        bool one_of_several, std::vector<SensorMount>* mounts) {
    for (int k = 0; k < n; ++k) {
        double s, side;
        if (zig_zag) {
            s = s_middle + (k - (n - 1) / 2.0) * 25.0;
            side = (k % 2 == 0) ? -1.0 : 1.0;
        } else {
            const int pairs = (n + 1) / 2;
            s = s_middle + (k / 2 - (pairs - 1) / 2.0) * 40.0;
            side = (k % 2 == 0) ? -1.0 : 1.0;
        }
        if (one_of_several && (s < kRoadEndMarginM || s > centre.length() - kRoadEndMarginM)) {
            const auto metres = [](double m) { return std::to_string(std::lround(m)) + " m"; };
            throw std::invalid_argument(
                "sim: the stations do not fit on the " + metres(centre.length()) +
                " road: a pole would stand at " + metres(s) + " along it, within " +
                metres(kRoadEndMarginM) +
                " of an end (fewer stations or sensors per station, or a smaller "
                "--station-spacing-m)");
        }
        mounts->push_back(street_mount(centre, s, side, s_middle));
    }
}

Scene build_street(const Path& centre, const SceneParams& p, bool zig_zag,
                   const RoadsideParams& roadside_in) {
    Scene scene;
    scene.scenario = p.scenario;
    const int per_station = p.sensors / p.stations;
    for (int j = 0; j < p.stations; ++j) {
        const double s_middle =
            centre.length() / 2 + (j - (p.stations - 1) / 2.0) * p.station_spacing_m;
        add_station_mounts(centre, s_middle, per_station, zig_zag, p.stations > 1, &scene.mounts);
    }
    CounterRng rng(p.seed, 0x7363656E65ULL /* "scene" */, static_cast<std::uint64_t>(p.scenario));
    RoadsideParams roadside = roadside_in;
    roadside.keep_out = pole_positions(scene.mounts);
    add_road_surface(scene.mesh, centre, 0.0, centre.length());
    add_sidewalks(scene.mesh, centre, 0.0, centre.length());
    add_roadside(scene.mesh, centre, 0.0, centre.length(), roadside, rng);
    scene.tracks = street_tracks(centre, 0.0, centre.length());
    finish(scene);
    return scene;
}

Scene build_curve(const SceneParams& p) {
    // A 90 m radius bend (centre line), 2.4 rad long, bending to the left; the station's
    // middle is at the origin.
    const double r = 90.0;
    const Path centre(arc_points({0.0, r}, r, -M_PI / 2 - 1.2, -M_PI / 2 + 1.2, 1.0));
    RoadsideParams roadside;
    roadside.tree_spacing_m = 30.0;  // sparse vegetation
    roadside.tree_probability = 0.5;
    return build_street(centre, p, false, roadside);
}

Scene build_straight(const SceneParams& p) {
    const Path centre({{-160.0, 0.0}, {160.0, 0.0}});
    RoadsideParams roadside;
    roadside.tree_spacing_m = 14.0;  // buildings and vegetation
    roadside.tree_probability = 0.8;
    return build_street(centre, p, true, roadside);
}

constexpr double kJunctionHalfSizeM = street::kSidewalkOuterM;  // the junction box
constexpr double kArmLengthM = 160.0;  // from the junction centre to the arm's end

// Sensors on the arms (E, N, W, S, then further out), left of the outward direction,
// looking at the junction centre.
std::vector<SensorMount> intersection_mounts(int sensors) {
    std::vector<SensorMount> mounts;
    for (int k = 0; k < sensors; ++k) {
        const double a = (k % 4) * M_PI / 2;
        const Eigen::Vector2d out(std::cos(a), std::sin(a)), left(-out.y(), out.x());
        const double dist = 35.0 + 20.0 * (k / 4);
        SensorMount m;
        const Eigen::Vector2d xy = dist * out + kPoleLateralM * left;
        m.pole_base = Eigen::Vector3d(xy.x(), xy.y(), 0.0);
        m.yaw_rad = yaw_towards(m.pole_base, Eigen::Vector2d::Zero());
        mounts.push_back(m);
    }
    return mounts;
}

// The junction box and the four arms with their roadside, stop lines and traffic lights.
void add_intersection_arms(const RoadsideParams& roadside, CounterRng& rng, Mesh& mesh) {
    using namespace street;
    const double box = kJunctionHalfSizeM;
    mesh.add_quad({-box, -box, 0}, {box, -box, 0}, {box, box, 0}, {-box, box, 0},
                  Material::kAsphalt);
    for (int arm = 0; arm < 4; ++arm) {
        const double a = arm * M_PI / 2;
        const Eigen::Vector2d out(std::cos(a), std::sin(a));
        const Path centre({box * out, kArmLengthM * out});
        add_road_surface(mesh, centre, 0.0, centre.length());
        add_sidewalks(mesh, centre, 0.0, centre.length());
        add_roadside(mesh, centre, 3.0, centre.length(), roadside, rng);
        // Stop line across the inbound lanes (left of the outward direction), and the
        // signal for the inbound traffic, seen along the inbound direction.
        const Path inbound = centre.reversed();
        mesh.add_quad(street_point(inbound, inbound.length() - 2.0, -kRoadHalfWidthM, 0.001),
                      street_point(inbound, inbound.length() - 1.6, -kRoadHalfWidthM, 0.001),
                      street_point(inbound, inbound.length() - 1.6, -0.1, 0.001),
                      street_point(inbound, inbound.length() - 2.0, -0.1, 0.001),
                      Material::kLaneMarking);
        add_traffic_light(mesh, inbound, inbound.length() - 1.0);
    }
}

// Corner blocks: large buildings filling each quadrant near the junction.
void add_corner_blocks(CounterRng& rng, Mesh& mesh) {
    using namespace street;
    for (int q = 0; q < 4; ++q) {
        const double sx = (q & 1) ? 1.0 : -1.0, sy = (q & 2) ? 1.0 : -1.0;
        const double size = 32.0, h = rng.uniform(14.0, 22.0);
        const double c = kBuildingLineM + size / 2;
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.translation() = Eigen::Vector3d(sx * c, sy * c, h / 2);
        mesh.add_box(T, {size / 2, size / 2, h / 2}, Material::kFacade, false);
        // Entrance canopy on one facade breaks the corner's symmetry.
        T.translation() = Eigen::Vector3d(sx * (kBuildingLineM - 1.0), sy * (c + 5.0), 3.2);
        mesh.add_box(T, {1.0, 3.0, 0.15}, Material::kMetal);
    }
}

// Through traffic on both axes; each axis is its own signal group.
std::vector<Track> intersection_tracks() {
    const double box = kJunctionHalfSizeM;
    std::vector<Track> tracks;
    for (int axis = 0; axis < 2; ++axis) {
        const Eigen::Vector2d d = axis == 0 ? Eigen::Vector2d(1, 0) : Eigen::Vector2d(0, 1);
        const Path through({-kArmLengthM * d, kArmLengthM * d});
        for (auto& t : street_tracks(through, 0.0, through.length())) {
            if (t.kind == TrackKind::kRoadLane) {
                t.signal_group = axis;
                t.conflict_begin_m = kArmLengthM - box;
                t.conflict_end_m = kArmLengthM + box;
                tracks.push_back(std::move(t));
            }
        }
        // Cyclists and pedestrians stay on their arm (they turn off at the corner).
        for (int sign : {-1, 1}) {
            const Path arm_path({sign * box * d, sign * kArmLengthM * d});
            for (auto& t : street_tracks(arm_path, 0.0, arm_path.length())) {
                if (t.kind != TrackKind::kRoadLane) tracks.push_back(std::move(t));
            }
        }
    }
    return tracks;
}

Scene build_intersection(const SceneParams& p) {
    Scene scene;
    scene.scenario = p.scenario;
    scene.signals = SignalPlan{};
    scene.mounts = intersection_mounts(p.sensors);
    CounterRng rng(p.seed, 0x7363656E65ULL, static_cast<std::uint64_t>(p.scenario));
    RoadsideParams roadside;
    roadside.keep_out = pole_positions(scene.mounts);
    roadside.buildings_from_m = 52.0;  // the corner blocks below cover the first 50 m
    roadside.tree_spacing_m = 20.0;
    add_intersection_arms(roadside, rng, scene.mesh);
    add_corner_blocks(rng, scene.mesh);
    scene.tracks = intersection_tracks();
    finish(scene);
    return scene;
}

}  // namespace

const char* to_string(Scenario s) {
    switch (s) {
        case Scenario::kCurve:
            return "curve";
        case Scenario::kStraight:
            return "straight";
        case Scenario::kIntersection:
            return "intersection";
    }
    return "?";
}

std::optional<Scenario> scenario_from_string(const std::string& name) {
    if (name == "curve") return Scenario::kCurve;
    if (name == "straight") return Scenario::kStraight;
    if (name == "intersection") return Scenario::kIntersection;
    return std::nullopt;
}

bool SignalPlan::green_during(int group, double t0_s, double t1_s) const {
    const double cycle = cycle_s();
    const double start = group == 0 ? 0.0 : green_s + clearance_s;
    // Green windows are [start + k cycle, start + k cycle + green_s).
    const double k = std::floor((t0_s - start) / cycle);
    const double w0 = start + k * cycle;
    return t0_s >= w0 && t1_s <= w0 + green_s;
}

Scene build_scene(const SceneParams& p) {
    if (p.sensors < 1 || p.sensors > 16) {
        throw std::invalid_argument("sim: --sensors must be in 1..16, got " +
                                    std::to_string(p.sensors));
    }
    if (p.stations < 1 || p.sensors % p.stations != 0) {
        throw std::invalid_argument("sim: --stations must divide the sensors, got " +
                                    std::to_string(p.stations) + " stations for " +
                                    std::to_string(p.sensors) + " sensors");
    }
    if (p.stations > 1 && p.scenario == Scenario::kIntersection) {
        throw std::invalid_argument(
            "sim: several stations stand along one road: --scenario straight or curve");
    }
    if (p.stations > 1 && !(p.station_spacing_m > 0)) {
        throw std::invalid_argument("sim: --station-spacing-m must be positive");
    }
    switch (p.scenario) {
        case Scenario::kCurve:
            return build_curve(p);
        case Scenario::kStraight:
            return build_straight(p);
        case Scenario::kIntersection:
            return build_intersection(p);
    }
    throw std::invalid_argument("sim: unknown scenario");
}

}  // namespace lidarfuse::sim
