// Scene layout: sensors where PAPER.md puts them, neighboring sensors share a large part
// of their view (registration needs overlap), the intersection's corner buildings block
// the direct line of sight between neighboring sensors, and road users of every class
// move along their tracks at plausible speeds.
#include <gtest/gtest.h>

#include <cstdio>
#include <set>

#include "drivers/sim/ray_caster.hpp"
#include "drivers/sim/scene.hpp"
#include "drivers/sim/sensor_model.hpp"
#include "drivers/sim/sensor_rig.hpp"
#include "drivers/sim/traffic.hpp"

namespace lidarfuse::sim {
namespace {

std::vector<SensorRig> rigs_for(const Scene& scene) {
    std::vector<SensorRig> rigs;
    for (std::size_t k = 0; k < scene.mounts.size(); ++k) {
        SensorRigParams p;
        p.index = static_cast<int>(k);
        p.motion = false;
        rigs.emplace_back(scene.mounts[k], p);
    }
    return rigs;
}

// Share of the static points sensor `a` sees (every 8th column) that sensor `b` also sees:
// within b's vertical field of view and 100 m, and not occluded from b.
double view_overlap(const StaticScene& caster, const SensorRig& a, const SensorRig& b) {
    const ColumnRenderer renderer(a.info(), {});
    const auto& lut = renderer.lut();
    const Eigen::Isometry3d Ta = a.nominal_T_world_sensor(), Tb = b.nominal_T_world_sensor();
    const double min_alt = -0.17 * M_PI / 180, max_alt = 21.05 * M_PI / 180;
    int seen = 0, shared = 0;
    for (int m = 0; m < lut.width; m += 8) {
        for (int row = 0; row < lut.height; ++row) {
            const Eigen::Index i = static_cast<Eigen::Index>(row) * lut.width + m;
            const Eigen::Vector3d o = Ta * Eigen::Vector3d(lut.offset.row(i).transpose());
            const Eigen::Vector3d d = Ta.linear() * lut.direction.row(i).transpose();
            const RayHit h = caster.cast(o, d, 0.02, 100.0, nullptr, 0.f);
            if (!h.hit) continue;
            ++seen;
            const Eigen::Vector3d p = o + h.distance_m * d;
            const Eigen::Vector3d in_b = Tb.inverse() * p;
            const double r = in_b.norm();
            const double alt = std::asin(in_b.z() / r);
            if (r > 100.0 || alt < min_alt || alt > max_alt) continue;
            const Eigen::Vector3d ob = Tb.translation();
            const RayHit hb = caster.cast(ob, (p - ob).normalized(), 0.02, 100.0, nullptr, 0.f);
            if (hb.hit && hb.distance_m > (p - ob).norm() - 0.05) ++shared;
        }
    }
    return seen > 0 ? static_cast<double>(shared) / seen : 0.0;
}

class SimScenes : public ::testing::TestWithParam<Scenario> {};

TEST_P(SimScenes, SensorsStandOnSixMetrePolesAndNeighborsOverlap) {
    const Scene scene = build_scene({GetParam(), 4, 1});
    ASSERT_EQ(scene.mounts.size(), 4u);
    const RayDevice device;
    const StaticScene caster(device, scene.mesh);
    const auto rigs = rigs_for(scene);
    for (const auto& rig : rigs) {
        const Eigen::Isometry3d T = rig.nominal_T_world_sensor();
        EXPECT_NEAR(T.translation().z(), 6.0, 1e-9);
        // x (forward) pitched 17 degrees down.
        EXPECT_NEAR(std::asin(-(T.linear() * Eigen::Vector3d::UnitX()).z()), 17 * M_PI / 180, 1e-9);
    }
    // Neighbors along the station: 0-1, 1-2, 2-3 (and 3-0 around the intersection).
    const int pairs = GetParam() == Scenario::kIntersection ? 4 : 3;
    for (int k = 0; k < pairs; ++k) {
        const auto& a = rigs[static_cast<std::size_t>(k)];
        const auto& b = rigs[static_cast<std::size_t>((k + 1) % 4)];
        const double ab = view_overlap(caster, a, b), ba = view_overlap(caster, b, a);
        std::printf("%s: overlap %s->%s %.2f, %s->%s %.2f\n", to_string(GetParam()),
                    a.name().c_str(), b.name().c_str(), ab, b.name().c_str(), a.name().c_str(), ba);
        EXPECT_GT(std::max(ab, ba), 0.2);
        EXPECT_GT(std::min(ab, ba), 0.1);
    }
}

INSTANTIATE_TEST_SUITE_P(All, SimScenes,
                         ::testing::Values(Scenario::kCurve, Scenario::kStraight,
                                           Scenario::kIntersection));

// Two 4-sensor stations along one road (`sim --stations 2`), 80 m apart: the middles are
// 80 m apart along the road, and some sensor of one station shares at least as much of its
// view with one of the other as neighbors within a station must (0.1 both ways, above),
// which a segment's station-to-station registration needs.
class SimStationsAlongARoad : public ::testing::TestWithParam<Scenario> {};

TEST_P(SimStationsAlongARoad, NeighboringStationsShareTheirView) {
    const Scene scene = build_scene({GetParam(), 8, 1, 2, 80.0});
    ASSERT_EQ(scene.mounts.size(), 8u);
    Eigen::Vector3d middle[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    for (std::size_t k = 0; k < 8; ++k) middle[k / 4] += scene.mounts[k].pole_base / 4.0;
    // Along the road: 80 m on the straight road, the chord of an 80 m arc on the curve.
    const double expected = GetParam() == Scenario::kStraight ? 80.0 : 2 * 90 * std::sin(40.0 / 90);
    EXPECT_NEAR((middle[1] - middle[0]).norm(), expected, 2.0);
    const RayDevice device;
    const StaticScene caster(device, scene.mesh);
    const auto rigs = rigs_for(scene);
    // The stations' best-shared pair of sensors: what a station's fused cloud shares with
    // the next one's at least.
    double best = 0.0;
    std::string pair;
    for (std::size_t a = 0; a < 4; ++a) {
        for (std::size_t b = 4; b < 8; ++b) {
            const double shared = std::min(view_overlap(caster, rigs[a], rigs[b]),
                                           view_overlap(caster, rigs[b], rigs[a]));
            if (shared > best) {
                best = shared;
                pair = rigs[a].name() + "-" + rigs[b].name();
            }
        }
    }
    std::printf("%s, two stations: best shared view %s %.2f\n", to_string(GetParam()), pair.c_str(),
                best);
    EXPECT_GT(best, 0.1);
}

INSTANTIATE_TEST_SUITE_P(StreetScenes, SimStationsAlongARoad,
                         ::testing::Values(Scenario::kCurve, Scenario::kStraight));

TEST(SimScene, IntersectionCornerBuildingsBlockNeighboringSensors) {
    const Scene scene = build_scene({Scenario::kIntersection, 4, 1});
    const RayDevice device;
    const StaticScene caster(device, scene.mesh);
    const auto rigs = rigs_for(scene);
    for (int k = 0; k < 4; ++k) {
        const Eigen::Vector3d a = rigs[k].nominal_T_world_sensor().translation();
        const Eigen::Vector3d b = rigs[(k + 1) % 4].nominal_T_world_sensor().translation();
        const RayHit h =
            caster.cast(a, (b - a).normalized(), 0.5, (b - a).norm() - 0.5, nullptr, 0.f);
        EXPECT_TRUE(h.hit) << "line of sight lidar" << k << " -> lidar" << (k + 1) % 4;
        if (h.hit) {
            EXPECT_EQ(h.material, Material::kFacade);
        }
    }
}

TEST(SimScene, EveryClassOfRoadUserMovesAlongItsTrack) {
    const Scene scene = build_scene({Scenario::kStraight, 4, 1});
    const Traffic traffic(scene, {10.0, 1, 1.0});
    std::set<AgentClass> classes;
    for (const auto& a : traffic.agents()) classes.insert(a.cls);
    EXPECT_EQ(classes.size(), 5u);
    for (const auto& a : traffic.agents()) {
        const Track& track = scene.tracks[static_cast<std::size_t>(a.track)];
        const double t = a.enter_time_s + 0.5 * track.path.length() / track.speed_mps;
        const Eigen::Vector3d p0 = traffic.agent_pose(a, t).translation();
        const Eigen::Vector3d p1 = traffic.agent_pose(a, t + 1.0).translation();
        EXPECT_NEAR((p1 - p0).norm(), track.speed_mps, 0.05 * track.speed_mps);
        const double kmh = 3.6 * track.speed_mps;
        if (a.cls == AgentClass::kPedestrian) {
            EXPECT_LT(kmh, 7.0);
        }
        if (a.cls == AgentClass::kBicycle) {
            EXPECT_LT(kmh, 30.0);
        }
        if (a.cls == AgentClass::kCar || a.cls == AgentClass::kTruck) {
            EXPECT_LT(kmh, 70.0);
        }
    }
    std::vector<MovingBox> boxes;
    traffic.moving_boxes(5.0, 5.05, &boxes);
    EXPECT_GT(boxes.size(), 20u);
    for (const auto& b : boxes) {
        const double moved =
            (b.T_world_box_t1.translation() - b.T_world_box_t0.translation()).norm();
        EXPECT_LT(moved, 16.0 * 0.05 + 1e-6);
    }
}

}  // namespace
}  // namespace lidarfuse::sim
