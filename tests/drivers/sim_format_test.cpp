// The simulator's files follow their contracts: metadata that the ingest's parser and
// validator accept (real OS1-64 intrinsics, distinct identities, the capture's ports),
// station.yaml and ground_truth.csv exactly as specified, and packets of every supported
// profile that the ingest assembles without a single complaint.
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <utility>

#include "drivers/sim/os1_intrinsics.hpp"
#include "tests/drivers/sim_decode.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

std::string read_text(const std::filesystem::path& f) {
    std::ifstream in(f);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

TEST(SimFormat, EmbeddedIntrinsicsEqualTheRealOs1Metadata) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "same_ports_legacy.2.json");
    const auto info = ouster::load_metadata(file);
    ASSERT_EQ(info.beam_altitude_angles_deg.size(), 64u);
    for (int i = 0; i < 64; ++i) {
        EXPECT_DOUBLE_EQ(sim::os1_64::kBeamAltitudeDeg[i], info.beam_altitude_angles_deg[i]) << i;
        EXPECT_DOUBLE_EQ(sim::os1_64::kBeamAzimuthDeg[i], info.beam_azimuth_angles_deg[i]) << i;
    }
    EXPECT_DOUBLE_EQ(info.lidar_origin_to_beam_origin_mm, sim::os1_64::kLidarOriginToBeamOriginMm);
    EXPECT_DOUBLE_EQ(info.beam_to_lidar_transform(0, 3), sim::os1_64::kLidarOriginToBeamOriginMm);
    EXPECT_DOUBLE_EQ(info.lidar_to_sensor_transform(2, 3), sim::os1_64::kLidarToSensorZMm);
    EXPECT_EQ(info.prod_line, sim::os1_64::kProdLine);
}

class SimProfiles : public ::testing::TestWithParam<const char*> {};

TEST_P(SimProfiles, FilesFollowTheirContractsAndPacketsAssembleCleanly) {
    const std::string profile = GetParam();
    test::TempDir dir("sim_format");
    std::string log;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 3 --seconds 0.1"
                                    " --mode 512x20 --threads 2 --profile " +
                                    profile + " --out " + dir.path().string(),
                                &log),
              0)
        << log;

    EXPECT_EQ(read_text(dir.path() / "station.yaml"),
              "station: sim-curve\nroot: lidar0\nsensors:\n"
              "  - name: lidar0\n    udp_port: 7502\n    metadata: lidar0.json\n"
              "  - name: lidar1\n    udp_port: 7504\n    metadata: lidar1.json\n"
              "  - name: lidar2\n    udp_port: 7506\n    metadata: lidar2.json\n");
    std::ifstream gt(dir.path() / "ground_truth.csv");
    std::string header;
    std::getline(gt, header);
    EXPECT_EQ(header, "frame,sensor,t_ns,x,y,z,qw,qx,qy,qz");

    const auto cap = simtest::decode_sim_output(dir.path());
    ASSERT_EQ(cap.truth.size(), 2u * 3u);
    for (std::size_t i = 0; i < cap.truth.size(); ++i) {
        EXPECT_EQ(cap.truth[i].frame, static_cast<std::int64_t>(i / 3));
        EXPECT_EQ(cap.truth[i].sensor, "lidar" + std::to_string(i % 3));
        EXPECT_NEAR(cap.truth[i].pose.translation().z(), 6.0, 0.05);  // 6 m poles
    }
    std::set<std::string> serials;
    std::set<std::uint32_t> init_ids;
    for (const auto& s : cap.station.sensors) {
        SCOPED_TRACE(s.name);
        const auto& info = cap.infos.at(s.name);
        EXPECT_EQ(info.form, ouster::MetadataForm::kNested);
        EXPECT_TRUE(ouster::validate_sensor_info(info).empty());
        EXPECT_EQ(ouster::to_string(info.udp_profile_lidar), profile);
        EXPECT_EQ(info.udp_port_lidar, s.udp_port);
        EXPECT_EQ(info.lidar_mode, "512x20");
        serials.insert(info.prod_sn);
        init_ids.insert(info.init_id);
        const auto& c = cap.counters.at(s.name);
        EXPECT_EQ(c.lidar_packets, 2u * 32u);
        EXPECT_EQ(c.bad_size + c.bad_profile + c.crc_errors + c.late_packets + c.duplicate_packets +
                      c.bad_columns + c.frames_incomplete + c.resets + c.missing_columns,
                  0u);
        if (profile != "LEGACY") {
            EXPECT_EQ(c.crc_valid, c.lidar_packets);
        }
        const auto& scans = cap.scans.at(s.name);
        ASSERT_EQ(scans.size(), 2u);
        EXPECT_EQ((scans[0].frame_id + 1) & 0xFFFFu, scans[1].frame_id);
        for (const auto& scan : scans) {
            EXPECT_DOUBLE_EQ(scan.completeness, 1.0);
            if (profile != "LEGACY") {
                EXPECT_EQ(scan.init_id, info.init_id);
            }
            ASSERT_NE(simtest::truth_row(cap.truth, s.name, scan.first_column_ns), nullptr);
            if (profile == "RNG15_RFL8_NIR8") {
                for (auto r : scan.range_mm) ASSERT_EQ(r % 8, 0u);
            }
        }
    }
    EXPECT_EQ(serials.size(), 3u);
    EXPECT_EQ(init_ids.size(), 3u);
    EXPECT_GT(cap.pcap_stats.reassembled, 0u);
}

INSTANTIATE_TEST_SUITE_P(Profiles, SimProfiles,
                         ::testing::Values("LEGACY", "RNG19_RFL8_SIG16_NIR16", "RNG15_RFL8_NIR8"));

TEST(SimFormat, WholeDatagramsOptionWritesNoFragments) {
    test::TempDir dir("sim_whole");
    std::string log;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario straight --sensors 1 --seconds 0.05"
                                    " --mode 512x20 --whole-datagrams --out " +
                                    dir.path().string(),
                                &log),
              0)
        << log;
    const auto cap = simtest::decode_sim_output(dir.path());
    EXPECT_EQ(cap.pcap_stats.fragments, 0u);
    EXPECT_EQ(cap.pcap_stats.udp_datagrams, 32u);
}

TEST(SimFormat, BadArgumentsAreRejectedWithAMessage) {
    std::string log;
    EXPECT_NE(
        test::run_command(test::tool_path() + " sim --scenario roundabout --out /tmp/x", &log), 0);
    EXPECT_NE(log.find("scenario"), std::string::npos) << log;
    EXPECT_NE(test::run_command(
                  test::tool_path() + " sim --scenario curve --out /tmp/x --mode 1000x3", &log),
              0);
    EXPECT_NE(log.find("--mode"), std::string::npos) << log;
    EXPECT_NE(test::run_command(
                  test::tool_path() + " sim --scenario curve --out /tmp/x --fault drop:2", &log),
              0);
    EXPECT_NE(log.find("drop:2"), std::string::npos) << log;
    EXPECT_EQ(test::run_command(test::tool_path() + " sim --help", &log), 0);
    EXPECT_NE(log.find("clock-offset:SENSOR:OFFSET_S"), std::string::npos) << log;
}

// `--stations 2 --sensors-per-station 2`: one folder per station, each exactly what a
// 2-sensor station simulated alone writes (names, ports, a capture of its own sensors'
// packets only), with identities distinct across the road and the stations' middles
// --station-spacing-m apart; on the straight road, station 1 is station 0 moved along it.
TEST(SimFormat, StationsAlongARoadEachWriteAStationOfTheirOwn) {
    test::TempDir dir("sim_stations");
    std::string log;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario straight --stations 2 --sensors-per-station 2"
                                    " --station-spacing-m 90 --seconds 0.1 --mode 512x20"
                                    " --no-motion --no-traffic --out " +
                                    dir.path().string(),
                                &log),
              0)
        << log;
    std::set<std::string> serials;
    std::vector<simtest::DecodedCapture> caps;
    for (int j = 0; j < 2; ++j) {
        const auto folder = dir.path() / ("station" + std::to_string(j));
        SCOPED_TRACE(folder.string());
        EXPECT_EQ(read_text(folder / "station.yaml"),
                  "station: sim-straight-" + std::to_string(j) +
                      "\nroot: lidar0\nsensors:\n"
                      "  - name: lidar0\n    udp_port: 7502\n    metadata: lidar0.json\n"
                      "  - name: lidar1\n    udp_port: 7504\n    metadata: lidar1.json\n");
        caps.push_back(simtest::decode_sim_output(folder));
        const auto& cap = caps.back();
        ASSERT_EQ(cap.truth.size(), 2u * 2u);
        for (const auto& s : cap.station.sensors) {
            serials.insert(cap.infos.at(s.name).prod_sn);
            const auto& c = cap.counters.at(s.name);
            EXPECT_EQ(c.lidar_packets, 2u * 32u) << s.name;  // its own packets, no one else's
            EXPECT_EQ(c.duplicate_packets + c.late_packets + c.resets + c.frames_incomplete, 0u);
            EXPECT_EQ(cap.scans.at(s.name).size(), 2u) << s.name;
        }
    }
    EXPECT_EQ(serials.size(), 4u);
    ASSERT_EQ(caps.size(), 2u);
    for (std::size_t i = 0; i < caps[0].truth.size(); ++i) {
        const auto& a = caps[0].truth[i];
        const auto& b = caps[1].truth[i];
        EXPECT_EQ(a.sensor, b.sensor);
        EXPECT_TRUE((b.pose.translation() - a.pose.translation())
                        .isApprox(Eigen::Vector3d(90.0, 0.0, 0.0), 1e-9))
            << a.sensor << ": " << a.pose.translation().transpose() << " -> "
            << b.pose.translation().transpose();
        EXPECT_TRUE(b.pose.linear().isApprox(a.pose.linear(), 1e-9)) << a.sensor;
    }
}

TEST(SimFormat, StationsThatDoNotFitOrCannotBeLaidOutAreRejectedWithAMessage) {
    const std::string sim = test::tool_path() + " sim --out /tmp/lidarfuse-never-written ";
    const std::pair<const char*, const char*> cases[] = {
        {"--scenario intersection --stations 2", "straight or curve"},
        {"--scenario straight --stations 3 --station-spacing-m 150", "do not fit"},
        {"--scenario straight --stations 2 --sensors 4", "--sensors-per-station"},
        {"--scenario straight --stations 3 --sensors-per-station 6", "at most 16"},
        {"--scenario straight --stations 2 --fault drop:0.1", "--fault"},
        {"--scenario straight --station-spacing-m 5", "--station-spacing-m"},
    };
    for (const auto& [args, message] : cases) {
        std::string log;
        EXPECT_NE(test::run_command(sim + args, &log), 0) << args;
        EXPECT_NE(log.find(message), std::string::npos) << args << "\n" << log;
    }
    EXPECT_FALSE(std::filesystem::exists("/tmp/lidarfuse-never-written"));
}

}  // namespace
}  // namespace lidarfuse
