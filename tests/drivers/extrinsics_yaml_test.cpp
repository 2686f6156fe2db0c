// extrinsics.yaml (drivers/io/extrinsics_yaml): what `lidarfuse calibrate` and lidarfused
// write must read back exactly, and a damaged file must be refused naming the key.
#include "drivers/io/extrinsics_yaml.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <fstream>

#include "tests/support/test_data.hpp"

namespace lidarfuse::io {
namespace {

using ::testing::HasSubstr;

ExtrinsicsDocument sample_document() {
    ExtrinsicsDocument doc;
    doc.station = "roadside-17";
    doc.root = "lidar0";
    ExtrinsicsEntry root;
    root.name = "lidar0";
    root.registered = true;
    root.quality["points"] = 61234;
    doc.sensors.push_back(root);
    ExtrinsicsEntry moved;
    moved.name = "lidar1";
    moved.registered = true;
    moved.T_root_sensor.linear() =
        Eigen::AngleAxisd(2.9, Eigen::Vector3d(0.1, -0.2, 1.0).normalized()).toRotationMatrix();
    moved.T_root_sensor.translation() = Eigen::Vector3d(-31.123456789, 14.5, 0.25);
    doc.sensors.push_back(moved);
    ExtrinsicsEntry failed;
    failed.name = "lidar2";
    failed.reason = "no_consistent_candidate";
    failed.quality["keypoints"] = 12;
    doc.sensors.push_back(failed);
    ExtrinsicsPair pair;
    pair.source = "lidar1";
    pair.target = "lidar0";
    pair.status = "accepted";
    pair.figures["p2p_error_m"] = 0.0412;
    pair.figures["inliers"] = 5321;
    doc.pairs.push_back(pair);
    return doc;
}

TEST(ExtrinsicsYaml, DocumentRoundTripKeepsPosesReasonsAndPairFigures) {
    test::TempDir dir("extrinsics");
    const auto file = dir.path() / "extrinsics.yaml";
    const ExtrinsicsDocument doc = sample_document();
    write_extrinsics_yaml(file, doc);
    EXPECT_FALSE(std::filesystem::exists(file.string() + ".tmp"));
    const ExtrinsicsDocument back = read_extrinsics_document(file);
    EXPECT_EQ(back.station, "roadside-17");
    EXPECT_EQ(back.root, "lidar0");
    ASSERT_EQ(back.sensors.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(back.sensors[i].name, doc.sensors[i].name);
        EXPECT_EQ(back.sensors[i].registered, doc.sensors[i].registered);
        EXPECT_EQ(back.sensors[i].quality, doc.sensors[i].quality);
    }
    EXPECT_LT(
        (back.sensors[1].T_root_sensor.translation() - doc.sensors[1].T_root_sensor.translation())
            .norm(),
        1e-6);  // nine significant digits: micrometres at 100 m
    EXPECT_TRUE(back.sensors[1].T_root_sensor.linear().isApprox(
        doc.sensors[1].T_root_sensor.linear(), 1e-8));
    EXPECT_TRUE(back.sensors[0].T_root_sensor.isApprox(Eigen::Isometry3d::Identity()));
    EXPECT_EQ(back.sensors[2].reason, "no_consistent_candidate");
    ASSERT_EQ(back.pairs.size(), 1u);
    EXPECT_EQ(back.pairs[0].source, "lidar1");
    EXPECT_EQ(back.pairs[0].target, "lidar0");
    EXPECT_EQ(back.pairs[0].status, "accepted");
    EXPECT_EQ(back.pairs[0].figures, doc.pairs[0].figures);
}

TEST(ExtrinsicsYaml, AnUnregisteredSensorCarriesNoPose) {
    const std::string text = extrinsics_to_yaml(sample_document());
    const auto failed_at = text.find("name: lidar2");
    ASSERT_NE(failed_at, std::string::npos) << text;
    const std::string failed = text.substr(failed_at, text.find("pairs:") - failed_at);
    EXPECT_THAT(failed, HasSubstr("registered: false"));
    EXPECT_THAT(failed, HasSubstr("reason: no_consistent_candidate"));
    EXPECT_EQ(failed.find("T_root_sensor"), std::string::npos) << failed;
}

TEST(ExtrinsicsYaml, SensorsOnlyFormIsTheSameFile) {
    test::TempDir dir("extrinsics_sensors");
    const auto file = dir.path() / "extrinsics.yaml";
    const ExtrinsicsDocument doc = sample_document();
    write_extrinsics_yaml(file, "lidar0", doc.sensors);
    std::string root;
    const auto sensors = read_extrinsics_yaml(file, &root);
    EXPECT_EQ(root, "lidar0");
    ASSERT_EQ(sensors.size(), 3u);
    EXPECT_TRUE(read_extrinsics_document(file).pairs.empty());
}

void expect_refused(const std::string& text, const std::string& expected) {
    test::TempDir dir("extrinsics_bad");
    const auto file = dir.path() / "broken.yaml";
    std::ofstream(file) << text;
    try {
        read_extrinsics_document(file);
        FAIL() << "accepted:\n" << text;
    } catch (const std::runtime_error& error) {
        EXPECT_THAT(error.what(), HasSubstr("broken.yaml")) << error.what();
        EXPECT_THAT(error.what(), HasSubstr(expected)) << error.what();
    }
}

TEST(ExtrinsicsYaml, DamagedFilesAreRefusedNamingTheKey) {
    expect_refused("root: lidar0\n", "sensors: expected a list");
    expect_refused("sensors: [{name: a}]\n", "sensors[0].registered: missing");
    expect_refused("sensors: [{name: a, registered: true}]\n", "sensors[0].T_root_sensor");
    expect_refused(
        "sensors: [{name: a, registered: true, T_root_sensor: {translation: [1, 2], rotation_wxyz: "
        "[1, 0, 0, 0]}}]\n",
        "expected 3 + 4 numbers");
    expect_refused(
        "sensors: [{name: a, registered: true, T_root_sensor: {translation: [1, 2, 3], "
        "rotation_wxyz: [2, 0, 0, 0]}}]\n",
        "rotation_wxyz: not unit length");
    expect_refused(
        "sensors: [{name: a, registered: true, T_root_sensor: {translation: [.nan, 2, 3], "
        "rotation_wxyz: [1, 0, 0, 0]}}]\n",
        "translation: not finite");
    expect_refused("sensors: [{name: a, registered: false, quality: {points: lots}}]\n",
                   "sensors[0].quality.points: expected a number");
    expect_refused("sensors: []\npairs: [{source: a, status: accepted}]\n",
                   "pairs[0]: expected source and target");
    expect_refused("sensors: []\npairs: [{source: a, target: b, status: ok, inliers: many}]\n",
                   "pairs[0].inliers: expected a number");
    expect_refused("sensors: [\n", "broken.yaml");
}

// The world block lidarfused writes (road or geo) reads back exactly, and every registered
// sensor gets T_fused_sensor = T_fused_root * T_root_sensor beside its unchanged T_root_sensor.
TEST(ExtrinsicsYaml, WorldBlockRoundTripAndFusedPoses) {
    test::TempDir dir("extrinsics-world");
    const auto file = dir.path() / "extrinsics.yaml";
    ExtrinsicsDocument doc = sample_document();
    ExtrinsicsWorld w;
    w.frame = "geo";
    w.fused_frame = "lidarfuse/fused";
    w.T_fused_root.linear() =
        Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.1, 0.2, 1).normalized()).toRotationMatrix();
    w.T_fused_root.translation() = Eigen::Vector3d(0.4, -0.25, 0.2);
    w.world_frame = "utm";
    w.T_world_fused.translation() = Eigen::Vector3d(691234, 5335012, 512);
    w.figures["residual_rms_m"] = 0.0123;
    w.figures["residual_max_m"] = 0.0456;
    doc.world = w;
    write_extrinsics_yaml(file, doc);
    const ExtrinsicsDocument back = read_extrinsics_document(file);
    ASSERT_TRUE(back.world.has_value());
    EXPECT_EQ(back.world->frame, "geo");
    EXPECT_EQ(back.world->fused_frame, "lidarfuse/fused");
    EXPECT_EQ(back.world->world_frame, "utm");
    EXPECT_TRUE(back.world->T_fused_root.isApprox(w.T_fused_root, 1e-8));
    EXPECT_EQ(back.world->T_world_fused.translation(),
              w.T_world_fused.translation());  // whole metres, exact
    EXPECT_DOUBLE_EQ(back.world->figures.at("residual_max_m"), 0.0456);
    ASSERT_EQ(back.sensors.size(), doc.sensors.size());
    EXPECT_TRUE(back.sensors[1].T_root_sensor.isApprox(doc.sensors[1].T_root_sensor, 1e-8));
    // T_fused_sensor is in the file as the published pose.
    const YAML::Node yaml = YAML::LoadFile(file.string());
    const auto t = yaml["sensors"][1]["T_fused_sensor"]["translation"].as<std::vector<double>>();
    const Eigen::Vector3d expected = (w.T_fused_root * doc.sensors[1].T_root_sensor).translation();
    EXPECT_NEAR((Eigen::Vector3d(t[0], t[1], t[2]) - expected).norm(), 0.0, 1e-6);
    EXPECT_FALSE(yaml["sensors"][2]["T_fused_sensor"]);  // not registered: no pose at all

    // road: no world_frame; a file without a world block reads back without one.
    doc.world->frame = "road";
    doc.world->world_frame.clear();
    write_extrinsics_yaml(file, doc);
    const auto road = read_extrinsics_document(file);
    ASSERT_TRUE(road.world.has_value());
    EXPECT_TRUE(road.world->world_frame.empty());
    EXPECT_TRUE(road.world->T_world_fused.isApprox(Eigen::Isometry3d::Identity()));
    doc.world.reset();
    write_extrinsics_yaml(file, doc);
    EXPECT_FALSE(read_extrinsics_document(file).world.has_value());
}

// The block every writer (lidarfused, fuse, calibrate) makes from a core::WorldFrame.
TEST(ExtrinsicsYaml, WorldBlockFromAWorldFrame) {
    core::WorldFrame f;
    f.kind = core::WorldFrameKind::kGeo;
    f.fixed = true;
    f.T_fused_root.translation() = Eigen::Vector3d(1, 2, 3);
    f.T_world_fused.translation() = Eigen::Vector3d(691000, 5335000, 500);
    f.residual_rms_m = 0.03;
    f.residual_max_m = 0.04;
    f.num_sensors = 3;
    f.num_frames = 100;
    const ExtrinsicsWorld geo = extrinsics_world(f, "lidarfuse/fused", "utm");
    EXPECT_EQ(geo.frame, "geo");
    EXPECT_EQ(geo.fused_frame, "lidarfuse/fused");
    EXPECT_EQ(geo.world_frame, "utm");
    EXPECT_EQ(geo.T_world_fused.translation(), f.T_world_fused.translation());
    EXPECT_EQ(geo.figures.at("residual_max_m"), 0.04);
    EXPECT_EQ(geo.figures.at("sensors_used"), 3);
    EXPECT_EQ(geo.figures.at("frames_averaged"), 100);
    EXPECT_EQ(geo.figures.count("root_height_m"), 0u);
    f.kind = core::WorldFrameKind::kRoad;
    f.root_height_m = 6.1;
    const ExtrinsicsWorld road = extrinsics_world(f, "", "utm");
    EXPECT_TRUE(road.world_frame.empty());  // geo only
    EXPECT_TRUE(road.fused_frame.empty());
    EXPECT_EQ(road.figures.at("root_height_m"), 6.1);
    EXPECT_EQ(road.figures.count("residual_rms_m"), 0u);  // planes alone: not measured
    f.num_road_points = 5000;
    EXPECT_EQ(extrinsics_world(f, "", "utm").figures.at("residual_rms_m"), 0.03);
    EXPECT_EQ(road.figures.count("frames_averaged"), 0u);
    f.kind = core::WorldFrameKind::kSensor;
    EXPECT_TRUE(extrinsics_world(f, "", "utm").figures.empty());
}

}  // namespace
}  // namespace lidarfuse::io
