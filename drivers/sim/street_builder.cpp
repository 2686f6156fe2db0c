#include "drivers/sim/street_builder.hpp"

#include <algorithm>
#include <cmath>

namespace lidarfuse::sim {

using namespace street;

namespace {

constexpr double kStepM = 1.5;  // longitudinal tessellation of strips

Eigen::Vector2d smooth_left(const Path& centre, double s) {
    const double eps = 0.3;
    const Eigen::Vector2d t = (centre.tangent(std::max(0.0, s - eps)) +
                               centre.tangent(std::min(centre.length(), s + eps)))
                                  .normalized();
    return {-t.y(), t.x()};
}

std::vector<double> stations(double s0, double s1) {
    const int n = std::max(1, static_cast<int>(std::ceil((s1 - s0) / kStepM)));
    std::vector<double> out;
    for (int k = 0; k <= n; ++k) out.push_back(s0 + (s1 - s0) * k / n);
    return out;
}

// Flat band between two lateral offsets.
void add_band(Mesh& mesh, const Path& centre, const std::vector<double>& ss, double o0, double o1,
              double z, Material m) {
    for (std::size_t i = 0; i + 1 < ss.size(); ++i) {
        mesh.add_quad(street_point(centre, ss[i], o0, z), street_point(centre, ss[i + 1], o0, z),
                      street_point(centre, ss[i + 1], o1, z), street_point(centre, ss[i], o1, z),
                      m);
    }
}

// Vertical band at lateral offset o from z0 to z1 (a curb face).
void add_wall(Mesh& mesh, const Path& centre, const std::vector<double>& ss, double o, double z0,
              double z1, Material m) {
    for (std::size_t i = 0; i + 1 < ss.size(); ++i) {
        mesh.add_quad(street_point(centre, ss[i], o, z0), street_point(centre, ss[i + 1], o, z0),
                      street_point(centre, ss[i + 1], o, z1), street_point(centre, ss[i], o, z1),
                      m);
    }
}

Eigen::Isometry3d frame_at(const Path& centre, double s, double lateral_m, double z_m,
                           double extra_yaw = 0.0) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = street_point(centre, s, lateral_m, z_m);
    T.linear() = Eigen::AngleAxisd(centre.heading(s) + extra_yaw, Eigen::Vector3d::UnitZ())
                     .toRotationMatrix();
    return T;
}

bool kept_out(const RoadsideParams& p, const Eigen::Vector3d& at) {
    for (const auto& k : p.keep_out) {
        if ((at.head<2>() - k).norm() < 4.0) return true;
    }
    return false;
}

void add_building(Mesh& mesh, const Path& centre, double s, double side, double length_m,
                  CounterRng& rng) {
    const double depth = rng.uniform(10.0, 18.0);
    const double height = rng.uniform(7.0, 21.0);
    const double lateral = side * (kBuildingLineM + depth / 2);
    const Eigen::Isometry3d T = frame_at(centre, s, lateral, 0.0);
    Eigen::Isometry3d body = T;
    body.translation().z() = height / 2;
    mesh.add_box(body, {length_m / 2, depth / 2, height / 2}, Material::kFacade, false);
    // Pilasters on the street facade every ~5 m: breaks the symmetry of a plain wall along
    // the road (registration would otherwise slide along it).
    const int n = static_cast<int>(length_m / 5.0);
    for (int k = 0; k <= n; ++k) {
        const double x = -length_m / 2 + length_m * k / std::max(n, 1);
        Eigen::Isometry3d P = T;
        P.translation() += T.linear() * Eigen::Vector3d(x, -side * (depth / 2 + 0.15), 0);
        P.translation().z() = height / 2;
        mesh.add_box(P, {0.25, 0.15, height / 2}, Material::kConcrete, false);
    }
    // Shop window band and a rooftop plant room.
    Eigen::Isometry3d W = T;
    W.translation() += T.linear() * Eigen::Vector3d(0, -side * (depth / 2 + 0.02), 0);
    W.translation().z() = 2.0;
    mesh.add_box(W, {length_m / 2 - 0.6, 0.02, 1.0}, Material::kGlass, false);
    if (rng.uniform() < 0.6) {
        Eigen::Isometry3d R = T;
        R.translation() += T.linear() * Eigen::Vector3d(rng.uniform(-0.25, 0.25) * length_m,
                                                        rng.uniform(-0.2, 0.2) * depth, 0);
        R.translation().z() = height + 1.2;
        mesh.add_box(R, {rng.uniform(1.5, 3.5), rng.uniform(1.5, 3.0), 1.2}, Material::kMetal,
                     false);
    }
}

void add_tree(Mesh& mesh, const Eigen::Vector3d& base, CounterRng& rng) {
    const double trunk_h = rng.uniform(2.2, 3.5);
    mesh.add_cylinder(base, rng.uniform(0.12, 0.22), trunk_h + 0.5, Material::kBark, 8);
    const double rxy = rng.uniform(1.6, 2.8), rz = rng.uniform(1.8, 3.0);
    mesh.add_ellipsoid(base + Eigen::Vector3d(0, 0, trunk_h + 0.6 * rz), {rxy, rxy * 0.9, rz},
                       Material::kFoliage, 2);
}

void add_lamp(Mesh& mesh, const Path& centre, double s, double side) {
    const Eigen::Vector3d base = street_point(centre, s, side * 10.8, kCurbHeightM);
    mesh.add_cylinder(base, 0.09, 8.0, Material::kMetal, 8);
    Eigen::Isometry3d arm = frame_at(centre, s, side * 9.9, 7.9);
    mesh.add_box(arm, {0.05, 0.9, 0.05}, Material::kMetal);
    arm.translation() = street_point(centre, s, side * 9.3, 7.75);
    mesh.add_box(arm, {0.25, 0.35, 0.1}, Material::kMetal);
}

void add_sign(Mesh& mesh, const Path& centre, double s, double side) {
    const Eigen::Vector3d base = street_point(centre, s, side * 14.1, kCurbHeightM);
    mesh.add_cylinder(base, 0.04, 2.6, Material::kMetal, 6);
    Eigen::Isometry3d plate = frame_at(centre, s, side * 14.1, 2.55);
    mesh.add_box(plate, {0.02, 0.35, 0.35}, Material::kSignFace);
}

}  // namespace

Eigen::Vector3d street_point(const Path& centre, double s, double lateral_m, double z_m) {
    const Eigen::Vector2d p = centre.position(s) + lateral_m * smooth_left(centre, s);
    return {p.x(), p.y(), z_m};
}

void add_road_surface(Mesh& mesh, const Path& centre, double s0, double s1) {
    const auto ss = stations(s0, s1);
    // Markings 0.15 m wide (edge lines, dashed lane lines, solid centre line) and the
    // asphalt between them, from right to left; every band lies at z = 0, none overlap.
    const std::vector<std::pair<double, bool>> lines = {{-10.2, false}, {-7.0, true}, {-3.5, true},
                                                        {0.0, false},   {3.5, true},  {7.0, true},
                                                        {10.2, false}};
    double o = -kRoadHalfWidthM;
    for (const auto& [c, dashed] : lines) {
        add_band(mesh, centre, ss, o, c - 0.075, 0.0, Material::kAsphalt);
        for (std::size_t i = 0; i + 1 < ss.size(); ++i) {
            const bool paint = !dashed || std::fmod(std::floor(ss[i] / 3.0), 3.0) == 0.0;
            add_band(mesh, centre, {ss[i], ss[i + 1]}, c - 0.075, c + 0.075, 0.0,
                     paint ? Material::kLaneMarking : Material::kAsphalt);
        }
        o = c + 0.075;
    }
    add_band(mesh, centre, ss, o, kRoadHalfWidthM, 0.0, Material::kAsphalt);
}

void add_sidewalks(Mesh& mesh, const Path& centre, double s0, double s1) {
    const auto ss = stations(s0, s1);
    for (const double side : {-1.0, 1.0}) {
        const double a = side * kRoadHalfWidthM, b = side * kSidewalkOuterM;
        // Faces are emitted in both orders; the caster treats triangles as two-sided.
        add_wall(mesh, centre, ss, a, 0.0, kCurbHeightM, Material::kConcrete);
        add_band(mesh, centre, ss, a, b, kCurbHeightM, Material::kConcrete);
        add_wall(mesh, centre, ss, b, street::kGroundZM, kCurbHeightM, Material::kConcrete);
        add_band(mesh, centre, ss, b, side * kParkingOuterM, 0.0, Material::kConcrete);
    }
}

void add_roadside(Mesh& mesh, const Path& centre, double s0, double s1, const RoadsideParams& p,
                  CounterRng& rng) {
    for (const double side : {-1.0, 1.0}) {
        // Buildings in blocks along the side.
        double s = std::max(s0, p.buildings_from_m) + rng.uniform(0.0, 6.0);
        const double s_end = std::min(s1, p.buildings_to_m);
        while (s < s_end - 8.0) {
            const double len = std::min(rng.uniform(12.0, 26.0), s_end - s);
            if (rng.uniform() < p.building_probability) {
                add_building(mesh, centre, s + len / 2, side, len, rng);
            }
            s += len + rng.uniform(3.0, 9.0);
        }
        if (p.tree_spacing_m > 0) {
            for (double t = s0 + rng.uniform(2.0, p.tree_spacing_m); t < s1 - 2.0;
                 t += p.tree_spacing_m * rng.uniform(0.7, 1.3)) {
                const Eigen::Vector3d base = street_point(centre, t, side * 13.6, kCurbHeightM);
                if (rng.uniform() < p.tree_probability && !kept_out(p, base)) {
                    add_tree(mesh, base, rng);
                }
            }
        }
        for (double t = s0 + rng.uniform(3.0, p.lamp_spacing_m); t < s1 - 2.0;
             t += p.lamp_spacing_m) {
            if (!kept_out(p, street_point(centre, t, side * 10.8, 0)))
                add_lamp(mesh, centre, t, side);
        }
        for (double t = s0 + rng.uniform(5.0, p.sign_spacing_m); t < s1 - 2.0;
             t += p.sign_spacing_m * rng.uniform(0.6, 1.4)) {
            if (!kept_out(p, street_point(centre, t, side * 14.1, 0)))
                add_sign(mesh, centre, t, side);
        }
        for (double t = s0 + 4.0; t < s1 - 4.0; t += 6.0) {
            if (rng.uniform() < p.parked_car_probability) {
                const double yaw = side > 0 ? M_PI : 0.0;  // parked in the driving direction
                add_car(mesh, frame_at(centre, t, side * 16.0, 0.0, yaw), rng.uniform(3.9, 4.8),
                        Material::kCarPaint);
            }
        }
    }
}

void add_ground(Mesh& mesh, double h) {
    const double z = street::kGroundZM;
    mesh.add_quad({-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}, Material::kGrass);
}

void add_sensor_pole(Mesh& mesh, const SensorMount& mount) {
    mesh.add_cylinder(mount.pole_base, 0.12, mount.pole_height_m - 0.35, Material::kMetal, 10);
}

void add_car(Mesh& mesh, const Eigen::Isometry3d& T, double length_m, Material m) {
    Eigen::Isometry3d body = T;
    body.translation() += T.linear() * Eigen::Vector3d(0, 0, 0.65);
    mesh.add_box(body, {length_m / 2, 0.9, 0.4}, m);
    Eigen::Isometry3d cabin = T;
    cabin.translation() += T.linear() * Eigen::Vector3d(-0.1 * length_m, 0, 1.3);
    mesh.add_box(cabin, {0.28 * length_m, 0.8, 0.25}, Material::kGlass, false);
}

void add_traffic_light(Mesh& mesh, const Path& centre, double s) {
    const Eigen::Vector3d base = street_point(centre, s, -11.0, kCurbHeightM);
    mesh.add_cylinder(base, 0.12, 6.6, Material::kMetal, 10);
    // Mast arm over the lanes of this direction, one signal head per lane.
    const Eigen::Isometry3d arm = frame_at(centre, s, -6.0, 6.3);
    mesh.add_box(arm, {0.08, 5.0, 0.08}, Material::kMetal);
    for (const double o : {-8.75, -5.25, -1.75}) {
        mesh.add_box(frame_at(centre, s, o, 5.6), {0.2, 0.18, 0.55}, Material::kMetal);
    }
    // A pedestrian-height signal on the same pole.
    mesh.add_box(frame_at(centre, s, -11.0, 2.6), {0.15, 0.15, 0.35}, Material::kMetal);
}

std::vector<Track> street_tracks(const Path& centre, double s0, double s1) {
    std::vector<Eigen::Vector2d> pts;
    for (double s : stations(s0, s1)) pts.push_back(centre.position(s));
    const Path base(pts);
    std::vector<Track> out;
    // Inner to outer lane: speeds and headways; trucks only on the outer lane.
    const double lane_speed[3] = {15.5, 13.0, 10.5};
    const double lane_headway[3] = {4.5, 5.0, 6.0};
    for (const double dir : {1.0, -1.0}) {
        const Path forward = dir > 0 ? base : base.reversed();
        for (int l = 0; l < kLanesPerDirection; ++l) {
            Track t;
            t.path = forward.offset(-(l + 0.5) * kLaneWidthM);
            t.kind = TrackKind::kRoadLane;
            t.lane_index = l;
            t.speed_mps = lane_speed[l];
            t.mean_headway_s = lane_headway[l];
            out.push_back(std::move(t));
        }
        Track cycle;
        cycle.path = forward.offset(-11.3);
        cycle.kind = TrackKind::kCyclePath;
        cycle.z_m = kCurbHeightM;
        cycle.speed_mps = 5.0;
        cycle.mean_headway_s = 20.0;
        out.push_back(std::move(cycle));
        for (const double o : {-12.6, 12.9}) {  // both sidewalks, walking this direction
            Track walk;
            walk.path = forward.offset(o);
            walk.kind = TrackKind::kSidewalk;
            walk.z_m = kCurbHeightM;
            walk.speed_mps = o < 0 ? 1.35 : 1.2;
            walk.mean_headway_s = 14.0;
            out.push_back(std::move(walk));
        }
    }
    return out;
}

}  // namespace lidarfuse::sim
