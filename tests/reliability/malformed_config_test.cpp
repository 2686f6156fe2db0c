// Malformed, truncated or contradictory config and metadata: the daemon refuses to start
// and lists every problem, or, for a sensor marked `enabled: false`, starts without it and
// reports it DISABLED.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "daemon/daemon_config.hpp"
#include "daemon/pipeline.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/station/station_config.hpp"
#include "tests/reliability/station_fixture.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::reliability {
namespace {

using ::testing::HasSubstr;

// Found by fuzz/fuzz_station_config: a name with bytes 0xFF (or a comma, a newline)
// passed validation and then broke poses.csv rows, extrinsics.yaml keys and the YAML
// round trip. Names are now limited to [A-Za-z0-9_.-], 1..64 characters.
TEST(MalformedConfig, SensorNamesThatWouldCorruptOutputFilesAreRefused) {
    test::TempDir dir("cfg-names");
    std::ofstream(dir.path() / "m.json") << "{}";
    const std::string fuzzed = std::string("s\xff\xff\x51\xa9", 5);
    for (const std::string& bad : {std::string("a,b"), std::string("x y"), std::string("n:1"),
                                   fuzzed, std::string(65, 'a')}) {
        const std::string yaml =
            "sensors:\n  - name: \"" + bad + "\"\n    udp_port: 7502\n    metadata: m.json\n";
        try {
            station::parse_station_config(yaml, "s.yaml", dir.path());
            ADD_FAILURE() << "accepted the name \"" << bad << "\"";
        } catch (const station::ConfigError& error) {
            EXPECT_THAT(error.what(), HasSubstr("sensors[0].name: expected 1..64 characters"));
        }
    }
    for (const char* good : {"lidar0", "north-pole_2.top", "L"}) {
        const std::string yaml =
            std::string("sensors:\n  - {name: ") + good + ", udp_port: 7502, metadata: m.json}\n";
        EXPECT_EQ(station::parse_station_config(yaml, "s.yaml", dir.path()).sensors.at(0).name,
                  good);
    }
}

// Found by fuzz/fuzz_ouster_metadata: a number too large for a double made the JSON
// parser throw out_of_range, which escaped parse_metadata() as something other than
// MetadataError (a tool would print a bare nlohmann message without the file's name).
TEST(MalformedConfig, JsonNumberOverflowIsAMetadataErrorNamingTheFile) {
    const std::string text = R"({"lidar_mode": "1024x10", "beam_altitude_angles": [5.3e84133]})";
    try {
        ouster::parse_metadata(text, "overflow.json");
        FAIL() << "accepted a number beyond a double";
    } catch (const ouster::MetadataError& error) {
        EXPECT_THAT(error.what(), HasSubstr("overflow.json"));
        EXPECT_THAT(error.what(), HasSubstr("malformed JSON"));
    }
}

// Found by fuzz/fuzz_ouster_metadata: without lidar_origin_to_beam_origin_mm, n took the
// product line's default even where beam_to_lidar_transform says otherwise, so the nested
// form written back (both keys) contradicted itself and no longer parsed. n now follows
// the matrix when it is absent.
TEST(MalformedConfig, BeamOriginFollowsTheMatrixWhenAbsentAndTheRewrittenFormParses) {
    ouster::SensorInfo info;
    info.prod_line = "OS-0-64-U02";  // default n would be 27.67 mm
    info.beam_altitude_angles_deg.assign(64, 0.0);
    for (int r = 0; r < 64; ++r)
        info.beam_altitude_angles_deg[static_cast<std::size_t>(r)] = 40.0 - 1.25 * r;
    info.beam_azimuth_angles_deg.assign(64, 0.0);
    info.pixel_shift_by_row.assign(64, 0);
    info.lidar_origin_to_beam_origin_mm = 27.116;
    info.beam_to_lidar_transform = Eigen::Matrix4d::Identity();
    info.beam_to_lidar_transform(0, 3) = 27.116;
    ASSERT_TRUE(ouster::validate_sensor_info(info).empty());
    auto doc = nlohmann::json::parse(ouster::to_nested_json(info));
    ASSERT_TRUE(doc["beam_intrinsics"].contains("lidar_origin_to_beam_origin_mm"));
    doc["beam_intrinsics"].erase("lidar_origin_to_beam_origin_mm");
    const auto read = ouster::parse_metadata(doc.dump(), "no-n.json");
    EXPECT_NEAR(read.lidar_origin_to_beam_origin_mm, 27.116, 1e-9);
    const auto again = ouster::parse_metadata(ouster::to_nested_json(read), "rewritten.json");
    EXPECT_NEAR(again.lidar_origin_to_beam_origin_mm, 27.116, 1e-9);
}

class MalformedMetadata : public ::testing::Test {
protected:
    void SetUp() override {
        simulate(dir_.path(), 0.1, {});
        // lidar1's metadata cut in the middle, as a failed copy would leave it.
        std::ifstream in(dir_.path() / "lidar1.json");
        const std::string text((std::istreambuf_iterator<char>(in)),
                               std::istreambuf_iterator<char>());
        std::ofstream(dir_.path() / "lidar1.json", std::ios::trunc)
            << text.substr(0, text.size() / 2);
    }
    test::TempDir dir_{"cfg-meta"};
    test::TempDir out_{"cfg-out"};
};

TEST_F(MalformedMetadata, OneBrokenSensorStopsTheStartNamingItsFile) {
    const auto config = station_config(dir_.path(), out_.path(), 0);
    try {
        daemon::Pipeline pipeline(config);
        FAIL() << "started with a truncated metadata file";
    } catch (const std::exception& error) {
        EXPECT_THAT(error.what(), HasSubstr("lidar1"));
        EXPECT_THAT(error.what(), HasSubstr("lidar1.json"));
        EXPECT_THAT(error.what(), ::testing::Not(HasSubstr("\"lidar0\"")));
    }
}

TEST_F(MalformedMetadata, ADisabledBrokenSensorIsReportedDisabledAndTheOthersRun) {
    auto config = station_config(dir_.path(), out_.path(), 0);
    config.station.sensors[1].enabled = false;
    daemon::Pipeline pipeline(config);
    pipeline.start();
    const auto st = pipeline.stats();
    pipeline.stop();
    ASSERT_EQ(st.sensors.size(), 2u);
    EXPECT_EQ(st.sensors[1].state, daemon::SensorState::kDisabled);
    EXPECT_EQ(st.sensors[0].state, daemon::SensorState::kLost);  // enabled, no data yet
    EXPECT_EQ(pipeline.bound_ports().size(), 1u);                // only lidar0's socket
}

}  // namespace
}  // namespace lidarfuse::reliability
