// core/world_frame: the road frame from sensors' road planes (and the fused cloud), the geo
// frame from known sensor positions, and the tracker that fixes one and applies it.
#include "core/pipeline/world_frame.hpp"

#include <gtest/gtest.h>

#include <random>

#include "core/common/se3.hpp"

namespace lidarfuse::core {
namespace {

Eigen::Isometry3d pose(const Eigen::Vector3d& t, const Eigen::Vector3d& axis, double angle_deg) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
    T.translation() = t;
    return T;
}

// A station over the road z = 0 of a "world" W: sensors at 6 m, tilted; the root frame is
// the root sensor's. Each sensor's road plane in its own frame is what ground_plane.hpp finds.
struct RoadStation {
    std::vector<Eigen::Isometry3d> T_W_sensor = {pose({-20, -10, 6.0}, {0.3, 1, 0.2}, 17),
                                                 pose({15, 12, 6.5}, {-1, 0.4, 0}, 12),
                                                 pose({30, -8, 5.8}, {0.2, -1, 0.5}, 20)};
    Eigen::Isometry3d T_root_W() const { return T_W_sensor[0].inverse(); }
    RoadPlaneObservation observe(std::size_t s, double height_error_m = 0.0) const {
        RoadPlaneObservation o;
        o.T_root_sensor = T_root_W() * T_W_sensor[s];
        o.ground.found = true;
        o.ground.up = T_W_sensor[s].linear().transpose() * Eigen::Vector3d::UnitZ();
        o.ground.sensor_height_m = T_W_sensor[s].translation().z() + height_error_m;
        o.ground.num_inliers = 1000;
        return o;
    }
    // Road points (and a sidewalk 15 cm up, and a car) in the root frame.
    FusedCloud cloud() const {
        FusedCloud c;
        std::mt19937 rng(3);
        std::uniform_real_distribution<double> u(-40.0, 40.0);
        for (int i = 0; i < 20000; ++i) {
            const double x = u(rng), y = u(rng);
            const double z = std::abs(y) > 25 ? 0.15 : 0.0;
            c.points.push_back((T_root_W() * Eigen::Vector3d(x, y, z)).cast<float>());
            c.dynamic.push_back(0);
        }
        for (int i = 0; i < 2000; ++i) {  // a car roof, flagged dynamic
            c.points.push_back(
                (T_root_W() * Eigen::Vector3d(u(rng) / 10, u(rng) / 20, 0.05)).cast<float>());
            c.dynamic.push_back(1);
        }
        return c;
    }
};

TEST(WorldFrame, KindNamesRoundTripAndNothingElseIsAKind) {
    for (const auto kind : {WorldFrameKind::kRoad, WorldFrameKind::kGeo, WorldFrameKind::kSensor}) {
        EXPECT_EQ(world_frame_kind_from(to_string(kind)), kind);
    }
    EXPECT_FALSE(world_frame_kind_from("Road"));
    EXPECT_FALSE(world_frame_kind_from("unknown"));
    EXPECT_FALSE(world_frame_kind_from(""));
}

TEST(WorldFrame, RoadFrameHasZUpTheRoadAtZeroAndXAlongTheRoot) {
    const RoadStation st;
    // The planes disagree by +-3 cm in height; the fused cloud's road points fix that.
    const std::vector<RoadPlaneObservation> planes = {st.observe(0, 0.03), st.observe(1, -0.03),
                                                      st.observe(2)};
    const FusedCloud cloud = st.cloud();
    const WorldFrame f = estimate_road_frame(planes, Eigen::Isometry3d::Identity(), &cloud);
    ASSERT_TRUE(f.fixed) << f.note;
    EXPECT_EQ(f.num_sensors, 3u);
    EXPECT_GT(f.num_road_points, 1000u);
    EXPECT_LT(f.residual_rms_m, 0.005);
    // T_fused_W: a rotation about z and a horizontal shift only (road at z = 0, z up).
    const Eigen::Isometry3d T_fused_W = f.T_fused_root * st.T_root_W();
    EXPECT_NEAR((T_fused_W.linear() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ()).norm(),
                0.0, 1e-4);
    EXPECT_NEAR(T_fused_W.translation().z(), 0.0, 0.002);
    for (std::size_t s = 0; s < 3; ++s) {
        const Eigen::Isometry3d T_fused_sensor = T_fused_W * st.T_W_sensor[s];
        EXPECT_NEAR(T_fused_sensor.translation().z(), st.T_W_sensor[s].translation().z(), 0.003)
            << s;
    }
    // Origin below the root, x along its x axis projected on the road.
    const Eigen::Vector3d root = f.T_fused_root.translation();
    EXPECT_NEAR(root.head<2>().norm(), 0.0, 1e-9);
    EXPECT_NEAR(root.z(), 6.0, 0.003);
    EXPECT_NEAR(f.root_height_m, 6.0, 0.003);
    const Eigen::Vector3d root_x = f.T_fused_root.linear().col(0);
    EXPECT_NEAR(root_x.y(), 0.0, 1e-9);
    EXPECT_GT(root_x.x(), 0.0);
}

TEST(WorldFrame, RoadFrameFromPlanesAloneWithoutCloudAndNoneWithoutPlanes) {
    const RoadStation st;
    const WorldFrame f =
        estimate_road_frame({st.observe(0), st.observe(1)}, Eigen::Isometry3d::Identity(), nullptr);
    ASSERT_TRUE(f.fixed);
    EXPECT_NEAR(f.root_height_m, 6.0, 1e-9);
    RoadPlaneObservation none = st.observe(1);
    none.ground.found = false;
    EXPECT_FALSE(estimate_road_frame({none}, Eigen::Isometry3d::Identity(), nullptr).fixed);
}

// A registration's planes: the root's and the placed sensors', moved by T_root0_root; with no
// road seen the fused frame is the root frame, fixed, and says why.
TEST(WorldFrame, RoadPlanesOfARegistrationAndTheRootFrameWithoutARoad) {
    const RoadStation st;
    InitialRegistrationResult result;
    result.sensors.resize(3);
    for (std::size_t k = 0; k < 3; ++k) {
        const RoadPlaneObservation o = st.observe(k % 2);
        result.sensors[k].T_root_sensor = o.T_root_sensor;
        result.sensors[k].ground = o.ground;
    }
    result.sensors[1].registered = true;  // sensor 2 was not placed
    const Eigen::Isometry3d T_root0_root = pose({1, 2, 3}, {0, 0, 1}, 10);
    const auto planes = road_planes_of(result, T_root0_root);
    ASSERT_EQ(planes.size(), 2u);
    EXPECT_TRUE(planes[1].T_root_sensor.isApprox(T_root0_root * result.sensors[1].T_root_sensor));

    RoadPlaneObservation none = st.observe(1);
    none.ground.found = false;
    const WorldFrame f = road_frame_or_root_frame({none}, Eigen::Isometry3d::Identity(), nullptr);
    EXPECT_TRUE(f.fixed);
    EXPECT_TRUE(f.T_fused_root.isApprox(Eigen::Isometry3d::Identity()));
    EXPECT_NE(f.note.find("the fused frame is the root sensor's"), std::string::npos) << f.note;
    const WorldFrame road =
        road_frame_or_root_frame({st.observe(0)}, Eigen::Isometry3d::Identity(), nullptr);
    EXPECT_NEAR(road.root_height_m, 6.0, 1e-9);
}

TEST(WorldFrame, GeoFitReportsResidualsAndSplitsTheOffset) {
    // World = UTM-like coordinates; the root frame is sensor 0's.
    const Eigen::Isometry3d T_world_root = pose({691234.5, 5335012.25, 512.2}, {0.1, 0.2, 1}, 40);
    const std::vector<Eigen::Vector3d> in_root = {
        {0, 0, 0}, {30, 5, -1}, {12, -25, 0.5}, {40, 20, 2}};
    const std::vector<Eigen::Vector3d> delta = {
        {0.05, 0, 0}, {0, -0.05, 0}, {0, 0, 0.05}, {-0.03, 0.04, 0}};
    std::vector<Eigen::Vector3d> in_world;
    for (std::size_t i = 0; i < in_root.size(); ++i)
        in_world.push_back(T_world_root * in_root[i] + delta[i]);
    const WorldFrame f = fit_geo_frame(in_root, in_world);
    ASSERT_TRUE(f.fixed) << f.note;
    ASSERT_EQ(f.anchor_residuals_m.size(), 4u);
    const Eigen::Isometry3d fitted = f.T_world_fused * f.T_fused_root;
    double max_r = 0;
    for (std::size_t i = 0; i < in_root.size(); ++i) {
        const double r = (fitted * in_root[i] - in_world[i]).norm();
        EXPECT_NEAR(r, f.anchor_residuals_m[i], 1e-6);
        max_r = std::max(max_r, r);
        // The fitted positions are off the truth by at most the perturbation plus the residual.
        EXPECT_LE((fitted * in_root[i] - T_world_root * in_root[i]).norm(),
                  0.05 + f.residual_max_m + 1e-9);
    }
    EXPECT_NEAR(f.residual_max_m, max_r, 1e-9);
    EXPECT_GT(f.residual_rms_m, 0.005);
    EXPECT_LT(f.residual_rms_m, 0.05);
    // The offset is whole metres and only a translation; the fused coordinates stay small.
    const Eigen::Vector3d o = f.T_world_fused.translation();
    EXPECT_TRUE(f.T_world_fused.linear().isIdentity());
    EXPECT_EQ(o, o.array().round().matrix());
    EXPECT_LT(f.T_fused_root.translation().norm(), 1.0);
}

TEST(WorldFrame, GeoFitRefusesFewerThanThreeOrCollinearPositions) {
    EXPECT_FALSE(fit_geo_frame({{0, 0, 0}, {1, 0, 0}}, {{0, 0, 0}, {1, 0, 0}}).fixed);
    const WorldFrame line =
        fit_geo_frame({{0, 0, 0}, {10, 0, 0}, {20, 0, 0}}, {{5, 5, 0}, {15, 5, 0}, {25, 5, 0}});
    EXPECT_FALSE(line.fixed);
    EXPECT_NE(line.note.find("line"), std::string::npos);
}

TEST(WorldFrame, TrackerSensorIsTheRootFrameAndApplyLeavesPoselessSensorsAlone) {
    WorldFrameParams p;
    p.kind = WorldFrameKind::kSensor;
    WorldFrameTracker sensor(p, 2);
    EXPECT_TRUE(sensor.fixed());
    FrameOutput out;
    out.T_root_sensor = {Eigen::Isometry3d::Identity(), pose({3, 4, 5}, {0, 0, 1}, 30)};
    out.health.resize(2);
    out.health[0].pose_valid = out.health[1].pose_valid = true;
    out.cloud.points.push_back(Eigen::Vector3f(1, 2, 3));
    FrameOutput copy = out;
    sensor.apply(&copy);
    EXPECT_TRUE(copy.T_root_sensor[1].isApprox(out.T_root_sensor[1], 0));
    EXPECT_EQ(copy.cloud.points[0], out.cloud.points[0]);

    p.kind = WorldFrameKind::kGeo;
    p.T_world_root = pose({100.4, 200.6, 50}, {0, 0, 1}, 90);
    WorldFrameTracker geo(p, 2);
    ASSERT_TRUE(geo.fixed());
    out.health[1].pose_valid = false;
    copy = out;
    geo.apply(&copy);
    const Eigen::Isometry3d world = geo.frame().T_world_fused * copy.T_root_sensor[0];
    EXPECT_TRUE(world.isApprox(*p.T_world_root, 1e-12));
    EXPECT_TRUE(copy.T_root_sensor[1].isApprox(out.T_root_sensor[1], 0));  // no pose: untouched
    const Eigen::Vector3f expected =
        (geo.frame().T_fused_root * Eigen::Vector3d(1, 2, 3)).cast<float>();
    EXPECT_LT((copy.cloud.points[0] - expected).norm(), 1e-5f);
}

TEST(WorldFrame, RoadTrackerWaitsForTheInitialRegistration) {
    WorldFrameParams p;  // road is the default
    WorldFrameTracker road(p, 2);
    EXPECT_EQ(p.kind, WorldFrameKind::kRoad);
    EXPECT_FALSE(road.fixed());
    FrameOutput out;
    out.T_root_sensor.assign(2, Eigen::Isometry3d::Identity());
    out.health.resize(2);
    out.health[0].pose_valid = true;
    EXPECT_FALSE(road.update(out));  // no registration applied yet: nothing known
    EXPECT_FALSE(road.fixed());
}

// A station of one sensor has no initial registration: its own cloud gives the road.
TEST(WorldFrame, RoadTrackerOfASingleSensorUsesItsOwnCloud) {
    const RoadStation st;
    WorldFrameParams p;
    p.settle_frames = 2;
    WorldFrameTracker road(p, 1);
    FrameOutput out;
    out.T_root_sensor.assign(1, Eigen::Isometry3d::Identity());
    out.health.resize(1);
    out.health[0].pose_valid = true;
    out.cloud = st.cloud();
    for (std::int64_t f = 0; f < 2; ++f) {
        out.frame_index = f;
        EXPECT_FALSE(road.update(out)) << f;  // settling (the root's reference deskew)
    }
    out.frame_index = 2;
    ASSERT_TRUE(road.update(out));
    EXPECT_EQ(road.frame().frame_index, 2);
    EXPECT_NEAR(road.frame().root_height_m, 6.0, 0.005);
    const Eigen::Isometry3d T_fused_W = road.frame().T_fused_root * st.T_root_W();
    EXPECT_NEAR((T_fused_W.linear() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ()).norm(),
                0.0, 1e-3);
}

// geo from anchors on swaying poles: each anchor's position is averaged over
// geo_average_frames frames (from the first registration applied, none pending) before the
// fit, so a sway over one whole period cancels; one frame's poses carry the sway.
TEST(WorldFrame, GeoTrackerFitsTheAnchorsMeanPositionsOverTheWindow) {
    const Eigen::Isometry3d T_world_root = pose({691000.3, 5335000.7, 500}, {0.1, 0.2, 1}, 40);
    const std::vector<Eigen::Vector3d> rest = {
        {0, 0, 0}, {30, 5, 0.5}, {10, -25, -0.3}, {-5, 20, 1}};
    WorldFrameParams p;
    p.kind = WorldFrameKind::kGeo;
    p.geo_average_frames = 40;
    for (std::size_t s = 0; s < 3; ++s) p.anchors.push_back({s, T_world_root * rest[s]});
    p.anchors.push_back({3, T_world_root * rest[3]});  // tracked in too few frames: left out
    const auto run = [&](const WorldFrameParams& params) {
        WorldFrameTracker geo(params, 4);
        FrameOutput out;
        out.T_root_sensor.assign(4, Eigen::Isometry3d::Identity());
        out.health.resize(4);
        for (auto& h : out.health) h.pose_valid = true;
        out.initial_registration_pending = true;
        for (std::int64_t f = 0;; ++f) {
            out.frame_index = f;
            if (f == 5) {  // the registration applied: counted from here on
                out.applied_registration = FrameOutput::AppliedRegistration{};
                out.initial_registration_pending = false;
            } else {
                out.applied_registration.reset();
            }
            out.health[3].pose_valid = f >= 5 + 25;  // 15 of 40 frames
            // Sway: 30 cm in x and 20 cm in y, a period of 40 frames; anchor 2 out of phase.
            for (std::size_t s = 0; s < 4; ++s) {
                const double phase = 2 * M_PI * static_cast<double>(f - 5) / 40 + (s == 2 ? 1 : 0);
                out.T_root_sensor[s].translation() =
                    rest[s] + Eigen::Vector3d(0.3 * std::sin(phase), 0.2 * std::cos(phase), 0);
            }
            if (geo.update(out)) return geo.frame();
            EXPECT_LT(f, 200);
            if (f >= 200) return WorldFrame{};
        }
    };
    const WorldFrame f = run(p);
    ASSERT_TRUE(f.fixed);
    EXPECT_EQ(f.frame_index, 5 + 40 - 1);  // the 40th frame from the registration's
    EXPECT_EQ(f.num_frames, 40u);
    EXPECT_EQ(f.num_sensors, 3u);  // anchor 3 had a pose in 15 of the 40 frames
    EXPECT_LT(f.residual_max_m, 1e-6);
    const Eigen::Isometry3d fitted = f.T_world_fused * f.T_fused_root;
    EXPECT_TRUE(fitted.isApprox(T_world_root, 1e-9));

    p.geo_average_frames = 1;  // one frame's poses: the sway is in the residual
    const WorldFrame one = run(p);
    ASSERT_TRUE(one.fixed);
    EXPECT_EQ(one.frame_index, 5);
    EXPECT_GT(one.residual_max_m, 0.1);
}

}  // namespace
}  // namespace lidarfuse::core
