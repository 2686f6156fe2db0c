// `lidarfuse sim` -> `lidarfuse calibrate`, through the built binaries: the initial
// registration on simulated captures, compared with the simulator's ground truth
// (T_root_sensor = T_world_root^-1 * T_world_sensor at frame 0).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "core/common/se3.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/pose_csv.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

struct Estimate {
    bool registered = false;
    Eigen::Isometry3d T_root_sensor = Eigen::Isometry3d::Identity();
};

// Reads extrinsics.yaml with the project's reader (drivers/io/extrinsics_yaml.hpp).
std::map<std::string, Estimate> read_extrinsics(const std::string& path) {
    std::map<std::string, Estimate> result;
    for (const auto& entry : io::read_extrinsics_yaml(path, nullptr)) {
        result[entry.name] = Estimate{entry.registered, entry.T_root_sensor};
    }
    return result;
}

struct Outcome {
    int sensors = 0;
    int registered = 0;
    int wrong = 0;      // registered but beyond 3 cm / 0.1 deg
    int misplaced = 0;  // registered beyond 0.5 m / 5 deg: a look-alike, not a loose fit
    std::string detail;
};

// Calibrates the simulated station in folder `sim` and compares every registered sensor
// with its ground truth.
Outcome calibrate_station(const std::string& sim) {
    Outcome outcome;
    std::string out;
    // Exit status 2 means "some sensors not registered"; the file is written either way.
    const int status =
        test::run_command(test::tool_path() + " calibrate " + sim + "/capture.pcap --config " +
                              sim + "/station.yaml --out " + sim + "/extrinsics.yaml",
                          &out);
    EXPECT_TRUE(status == 0 || status == 2) << out;
    const auto estimates = read_extrinsics(sim + "/extrinsics.yaml");
    // A rigid fit of a whole sweep of a swaying sensor measures its pose near the middle of
    // the sweep, not at column 0 (the scan's timestamp): the truth is taken half-way
    // between frames 0 and 1 (one sweep apart). With pole motion, column-0 truth differs
    // from it by up to ~8 cm; without motion the two are equal.
    std::map<std::string, Eigen::Isometry3d> frame0, frame1, truth;
    for (const auto& record : io::read_pose_csv(sim + "/ground_truth.csv")) {
        if (record.frame == 0) frame0[record.sensor] = record.pose;
        if (record.frame == 1) frame1[record.sensor] = record.pose;
    }
    for (const auto& [name, T0] : frame0) {
        const auto it = frame1.find(name);
        EXPECT_NE(it, frame1.end()) << name << ": no frame 1 in the ground truth";
        if (it == frame1.end()) continue;
        Eigen::Isometry3d mid = Eigen::Isometry3d::Identity();
        mid.translation() = 0.5 * (T0.translation() + it->second.translation());
        mid.linear() = Eigen::Quaterniond(T0.linear())
                           .slerp(0.5, Eigen::Quaterniond(it->second.linear()))
                           .toRotationMatrix();
        truth[name] = mid;
    }
    EXPECT_TRUE(truth.count("lidar0")) << "no root in the ground truth";
    outcome.sensors = static_cast<int>(truth.size());
    for (const auto& [name, T_world_sensor] : truth) {
        const auto it = estimates.find(name);
        EXPECT_NE(it, estimates.end()) << name << " missing from extrinsics.yaml\n" << out;
        if (it == estimates.end() || !it->second.registered) continue;
        ++outcome.registered;
        const Eigen::Isometry3d T_root_sensor = truth["lidar0"].inverse() * T_world_sensor;
        const Eigen::Isometry3d delta = T_root_sensor.inverse() * it->second.T_root_sensor;
        const double dt_m =
            (it->second.T_root_sensor.translation() - T_root_sensor.translation()).norm();
        const double dr_deg = Eigen::AngleAxisd(delta.linear()).angle() * 180.0 / M_PI;
        outcome.detail +=
            name + ": " + std::to_string(dt_m) + " m " + std::to_string(dr_deg) + " deg\n";
        if (dt_m > 0.03 || dr_deg > 0.1) ++outcome.wrong;
        if (dt_m > 0.5 || dr_deg > 5.0) ++outcome.misplaced;
    }
    outcome.detail += out;
    return outcome;
}

// Simulates `sim_args`, calibrates, and compares every registered sensor with the truth.
Outcome simulate_and_calibrate(const std::string& sim_args) {
    test::TempDir dir("calibrate");
    const std::string d = dir.path().string();
    std::string out;
    if (test::run_command(test::tool_path() + " sim " + sim_args + " --out " + d + "/sim", &out) !=
        0) {
        ADD_FAILURE() << out;
        return {};
    }
    return calibrate_station(d + "/sim");
}

// The intersection's four arms look alike: with FPFH + RANSAC alone only the root was
// registered, and a look-alike once placed lidar1 onto the root's own position (54 m
// off). Seed 2 with pole motion is a station where the look-alikes pass every pairwise
// check for two pairs (3-0 rotated by 180 deg, 3-1 by 90 deg) and agree with each other;
// the consensus over all pairs must still place every sensor right.
TEST(CalibrateCommand, IntersectionRegistersEverySensorDespiteLookAlikes) {
    const Outcome o =
        simulate_and_calibrate("--scenario intersection --sensors 4 --seconds 0.1 --seed 2");
    EXPECT_EQ(o.sensors, 4);
    EXPECT_EQ(o.registered, 4) << o.detail;
    EXPECT_EQ(o.wrong, 0) << o.detail;
}

// Eight sensors on two rings round the crossing, 90 deg apart: scene and layout are
// four-fold symmetric, so a sensor's scan is its neighbour's turned by 90 deg, and the
// look-alikes of several pairs compose into a consistent set that explains more pairs than
// the right placements (bench/BENCHMARK.md, "8 sensors on the intersection"). Such
// sensors must be refused (retried later), never placed at a look-alike. Seed 1 without
// pole motion swaps two sensors (each at the other's place, turned by 180 deg), which no
// sampled tree showed ambiguous: the consensus's moves do (edge_consensus.hpp).
TEST(CalibrateCommand, ASymmetricCrossingOfEightSensorsPlacesNoneAtALookAlike) {
    const Outcome o = simulate_and_calibrate(
        "--scenario intersection --sensors 8 --seconds 0.1 --seed 1 --no-motion");
    EXPECT_EQ(o.sensors, 8);
    EXPECT_EQ(o.misplaced, 0) << o.detail;
    EXPECT_GE(o.registered, 2) << o.detail;
}

// Curve, seed 2, with pole motion, two sensors: the smallest station.
TEST(CalibrateCommand, CurveRegistersEverySensorAccurately) {
    const Outcome o = simulate_and_calibrate("--scenario curve --sensors 2 --seconds 0.1 --seed 2");
    EXPECT_EQ(o.sensors, 2);
    EXPECT_EQ(o.registered, 2) << o.detail;
    EXPECT_EQ(o.wrong, 0) << o.detail;
}

// A road segment of two 4-sensor stations 80 m apart (`sim --stations`): each station's
// folder is a station of its own, and registers as one.
TEST(CalibrateCommand, EveryStationOfARoadSegmentRegistersOnItsOwn) {
    test::TempDir dir("calibrate_segment");
    const std::string d = dir.path().string();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario straight --stations 2 --sensors-per-station "
                                    "4 --seconds 0.1 --seed 1 --out " +
                                    d,
                                &out),
              0)
        << out;
    for (const char* station : {"station0", "station1"}) {
        const Outcome o = calibrate_station(d + "/" + station);
        EXPECT_EQ(o.sensors, 4) << station;
        EXPECT_EQ(o.registered, 4) << station << "\n" << o.detail;
        EXPECT_EQ(o.wrong, 0) << station << "\n" << o.detail;
    }
}

// Station j's road frame in the simulator's world at `frame`: its root's true pose times the
// inverse of the station's estimate of it (its fused frame is that road frame).
Eigen::Isometry3d world_from_road(const std::string& sim, const std::string& poses, int frame) {
    Eigen::Isometry3d truth = Eigen::Isometry3d::Identity(), estimate = truth;
    for (const auto& r : io::read_pose_csv(sim + "/ground_truth.csv"))
        if (r.frame == frame && r.sensor == "lidar0") truth = r.pose;
    for (const auto& r : io::read_pose_csv(poses))
        if (r.frame == frame && r.sensor == "lidar0") estimate = r.pose;
    return truth * estimate.inverse();
}

// The same segment as one registration (issue 20): each station fused in its road frame,
// and `calibrate --cloud` of the two fused clouds with `registration.initial_method:
// stations` places station1 against station0 from nothing, within 5 cm / 0.1 deg of the
// truth (bench/segment_registration_check.sh: 0.7-2.8 cm / 0.012-0.047 deg at 60-80 m).
TEST(CalibrateCommand, TwoStationsOfARoadSegmentArePlacedFromTheirFusedClouds) {
    test::TempDir dir("calibrate_stations");
    const std::string d = dir.path().string(), tool = test::tool_path();
    std::string out;
    ASSERT_EQ(test::run_command(tool +
                                    " sim --scenario straight --stations 2 "
                                    "--sensors-per-station 4 --seconds 0.35 --seed 2 --quiet "
                                    "--out " +
                                    d + "/sim",
                                &out),
              0)
        << out;
    for (const char* j : {"0", "1"}) {
        const std::string station = d + "/sim/station" + j;
        ASSERT_EQ(test::run_command(tool + " fuse " + station + "/capture.pcap --config " +
                                        station + "/station.yaml --out " + d + "/F" + j +
                                        " --world road --save-cloud 5 --quiet",
                                    &out),
                  0)
            << out;
    }
    std::ofstream(d + "/segment.yaml") << "registration: {initial_method: stations}\n";
    ASSERT_EQ(test::run_command(tool + " calibrate --cloud station0=" + d +
                                    "/F0/fused_5.ply --cloud station1=" + d +
                                    "/F1/fused_5.ply --config " + d + "/segment.yaml --out " + d +
                                    "/extrinsics.yaml --quiet",
                                &out),
              0)
        << out;
    const auto estimates = read_extrinsics(d + "/extrinsics.yaml");
    ASSERT_TRUE(estimates.at("station1").registered) << out;
    const Eigen::Isometry3d truth =
        world_from_road(d + "/sim/station0", d + "/F0/poses.csv", 5).inverse() *
        world_from_road(d + "/sim/station1", d + "/F1/poses.csv", 5);
    const double error_m = core::translation_error_m(estimates.at("station1").T_root_sensor, truth);
    const double error_deg =
        core::rotation_error_deg(estimates.at("station1").T_root_sensor, truth);
    std::printf("station1 against the truth: %.2f cm / %.3f deg (%.1f m away)\n", error_m * 100,
                error_deg, truth.translation().norm());
    EXPECT_LT(error_m, 0.05) << out;
    EXPECT_LT(error_deg, 0.1) << out;
}

TEST(CalibrateCommand, MissingCaptureFailsWithItsName) {
    test::TempDir dir("calibrate_bad");
    const std::string d = dir.path().string();
    std::string out;
    const int status =
        test::run_command(test::tool_path() + " calibrate " + d + "/absent.pcap --config " + d +
                              "/absent.yaml --out " + d + "/extrinsics.yaml",
                          &out);
    EXPECT_EQ(status, 1) << out;
    EXPECT_NE(out.find("absent"), std::string::npos) << out;
    EXPECT_FALSE(std::ifstream(d + "/extrinsics.yaml").good());
}

// calibrate takes the initial-registration keys of the config's registration section, as
// lidarfused does, and refuses a bad one before decoding anything.
TEST(CalibrateCommand, BadRegistrationKeyIsRefusedWithItsPath) {
    test::TempDir dir("calibrate_cfg");
    const std::string d = dir.path().string();
    const std::string tool = test::tool_path();
    std::string out;
    ASSERT_EQ(test::run_command(tool + " sim --scenario curve --sensors 2 --seconds 0.1 --out " + d,
                                &out),
              0)
        << out;
    {
        std::ifstream in(d + "/station.yaml");
        std::ofstream config(d + "/bad.yaml");
        config << in.rdbuf() << "registration:\n  ransac_iterations: 5\n";
    }
    out.clear();
    EXPECT_EQ(test::run_command(tool + " calibrate " + d + "/capture.pcap --config " + d +
                                    "/bad.yaml --out " + d + "/extrinsics.yaml",
                                &out),
              1)
        << out;
    EXPECT_NE(out.find("registration.ransac_iterations"), std::string::npos) << out;
    EXPECT_FALSE(std::ifstream(d + "/extrinsics.yaml").good());
}

}  // namespace
}  // namespace lidarfuse
