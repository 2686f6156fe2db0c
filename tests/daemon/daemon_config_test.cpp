#include "daemon/daemon_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "tests/support/test_data.hpp"

namespace lidarfuse::daemon {
namespace {

using ::testing::HasSubstr;

class DaemonConfigTest : public ::testing::Test {
protected:
    void SetUp() override { std::ofstream(dir_.path() / "a.json") << "{}"; }
    test::TempDir dir_{"daemoncfg"};
    const std::string sensors_ = "sensors:\n  - {name: a, udp_port: 7502, metadata: a.json}\n";
};

TEST_F(DaemonConfigTest, DefaultsWhenSectionsAreAbsent) {
    const auto c = parse_daemon_config(sensors_, "s.yaml", dir_.path());
    EXPECT_EQ(c.station.sensors.size(), 1u);
    EXPECT_DOUBLE_EQ(c.fusion.voxel_size_m, 1.0);
    EXPECT_EQ(c.fusion.window_frames, 5);
    EXPECT_TRUE(c.fusion.remove_dynamic);
    EXPECT_EQ(c.output.directory, "/var/lib/lidarfuse");
    EXPECT_EQ(c.log_level, "info");
}

TEST_F(DaemonConfigTest, EveryPaperParameterIsAKey) {
    const auto c = parse_daemon_config(sensors_ + R"(
registration:
  voxel_size_m: 3
  window_frames: 7
  huber_delta: 2.5
  ransac_iterations: 5000
  p2p_cutoff_m: 1.5
  initial_max_voxel_size_m: 1.5
  threads: 1
dynamics: {attenuation: 0.8, range_threshold_m: 0.4, enabled: false}
sync: {deadline_ms: 40}
output: {directory: out, extrinsics_interval_frames: 5}
health: {stale_after_ms: 100, lost_after_ms: 1000}
logging: {level: debug}
)",
                                       "s.yaml", dir_.path());
    EXPECT_DOUBLE_EQ(c.fusion.voxel_size_m, 3.0);
    EXPECT_EQ(c.fusion.window_frames, 7);
    EXPECT_DOUBLE_EQ(c.fusion.huber_delta, 2.5);
    EXPECT_EQ(c.fusion.initial.pair.ransac.max_iterations, 5000);
    EXPECT_DOUBLE_EQ(c.fusion.initial.pair.p2p_cutoff_m, 1.5);
    EXPECT_DOUBLE_EQ(c.fusion.initial.features.octree.max_voxel_size_m, 1.5);
    EXPECT_DOUBLE_EQ(c.fusion.background.attenuation, 0.8);
    EXPECT_FALSE(c.fusion.remove_dynamic);
    EXPECT_DOUBLE_EQ(c.sync.deadline_ms, 40.0);
    EXPECT_EQ(c.output.directory, dir_.path() / "out");
    EXPECT_EQ(c.log_level, "debug");
}

// Problems of the station section and of the daemon's sections come in one list.
TEST_F(DaemonConfigTest, EveryProblemOfEverySectionIsListed) {
    try {
        parse_daemon_config(R"(
sensors:
  - {name: a, udp_port: 0, metadata: a.json}
registration: {voxel_size_m: -1, windw_frames: 3, threads: many}
dynamics: {attenuation: 2}
health: {stale_after_ms: 500, lost_after_ms: 100}
logging: {level: loud}
output: [1, 2]
)",
                            "bad.yaml", dir_.path());
        FAIL();
    } catch (const station::ConfigError& error) {
        const std::string text = error.what();
        EXPECT_THAT(text, HasSubstr("sensors[0].udp_port"));
        EXPECT_THAT(text, HasSubstr("registration.voxel_size_m: expected a number"));
        EXPECT_THAT(text, HasSubstr("registration.windw_frames: unknown key"));
        EXPECT_THAT(text, HasSubstr("registration.threads: expected an integer"));
        EXPECT_THAT(text, HasSubstr("dynamics.attenuation"));
        EXPECT_THAT(text, HasSubstr("health.lost_after_ms: must not be below"));
        EXPECT_THAT(text, HasSubstr("logging.level: expected one of"));
        EXPECT_THAT(text, HasSubstr("output: expected a mapping"));
        EXPECT_EQ(error.problems().size(), 8u);
    }
}

}  // namespace
}  // namespace lidarfuse::daemon
