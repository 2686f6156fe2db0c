#include "drivers/capture/station_capture.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "tests/support/test_data.hpp"

namespace lidarfuse::capture {
namespace {

// The real OS1-64 capture through a one-sensor station: one complete frame, projected.
TEST(StationCapture, DecodesTheRealOs1Capture) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "OS-1-64_1024x10_fw20.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta, "OS-1-64_sensor_config_reduced.json");
    station::StationConfig config;
    config.root = "pole";
    config.sensors.push_back(
        {"pole", 7502, meta, std::nullopt, 1000, true, std::nullopt, 80, {}, std::nullopt});
    StationCapture capture(config, pcap);
    std::vector<std::uint32_t> frames;
    std::size_t points = 0;
    std::vector<float> dt;
    capture.run([&](const CaptureScan& scan) {
        frames.push_back(scan.scan->frame_id);
        points = scan.cloud->cloud.size();
        EXPECT_EQ(scan.sensor_t_ns, 278211490950);      // column 0 (DERIVED frame_summary)
        EXPECT_EQ(scan.t_ns, scan.sensor_t_ns + 1000);  // the configured time offset
        ouster::point_times_s(*scan.cloud, static_cast<std::uint64_t>(scan.sensor_t_ns), &dt);
        return true;
    });
    EXPECT_EQ(frames, std::vector<std::uint32_t>{189});
    // Golden (DERIVED reference frame_summary): 16,749 pixels with a return; columns from
    // 278211490950 to 278311354710 ns.
    EXPECT_EQ(points, 16749u);
    ASSERT_EQ(dt.size(), points);
    float latest = 0;
    for (float t : dt) {
        ASSERT_GE(t, 0.0f);
        latest = std::max(latest, t);
    }
    EXPECT_NEAR(latest, 0.09986376f, 2e-4f);
    EXPECT_EQ(capture.counters(0).frames_complete, 1u);
    EXPECT_EQ(capture.counters(0).imu_packets, 11u);
}

// Two sensors on one port (same_ports_legacy.pcap): each gets its own frame.
TEST(StationCapture, SharedPortSensorsAreToldApart) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(pcap, "same_ports_legacy.pcap");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta1, "same_ports_legacy.1.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta2, "same_ports_legacy.2.json");
    station::StationConfig config;
    config.root = "os0";
    config.sensors.push_back({"os0",
                              7502,
                              meta1,
                              std::string("169.254.92.158"),
                              0,
                              true,
                              std::nullopt,
                              80,
                              {},
                              std::nullopt});
    config.sensors.push_back({"os1",
                              7502,
                              meta2,
                              std::string("169.254.238.111"),
                              0,
                              true,
                              std::nullopt,
                              80,
                              {},
                              std::nullopt});
    StationCapture capture(config, pcap);
    std::vector<std::pair<std::size_t, std::uint32_t>> seen;
    capture.run([&](const CaptureScan& scan) {
        seen.emplace_back(scan.sensor, scan.scan->frame_id);
        return true;
    });
    std::sort(seen.begin(), seen.end());
    EXPECT_EQ(seen, (std::vector<std::pair<std::size_t, std::uint32_t>>{{0, 457}, {1, 185}}));
}

TEST(StationCapture, MissingMetadataNamesTheSensor) {
    test::TempDir dir("capture");
    station::StationConfig config;
    config.sensors.push_back({"north",
                              7502,
                              dir.path() / "north.json",
                              std::nullopt,
                              0,
                              true,
                              std::nullopt,
                              80,
                              {},
                              std::nullopt});
    std::ofstream(dir.path() / "north.json") << "{ not json";
    try {
        StationCapture capture(config, dir.path() / "none.pcap");
        FAIL();
    } catch (const std::exception& error) {
        EXPECT_THAT(error.what(), ::testing::HasSubstr("sensor \"north\""));
    }
}

// A sensor whose clouds come from DDS has nothing in a capture: the offline tools say so.
TEST(StationCapture, ADdsSourceIsRefusedNamingTheSensorAndTopic) {
    test::TempDir dir("capture");
    station::StationConfig config;
    station::SensorConfig sensor;
    sensor.name = "station1";
    sensor.dds = station::DdsSource{"rt/station1/points", 0, std::nullopt};
    config.sensors.push_back(sensor);
    try {
        StationCapture capture(config, dir.path() / "none.pcap");
        FAIL();
    } catch (const std::exception& error) {
        EXPECT_THAT(error.what(),
                    ::testing::HasSubstr("sensor \"station1\": takes its clouds "
                                         "from DDS (source.dds: rt/station1/points)"));
    }
}

}  // namespace
}  // namespace lidarfuse::capture
