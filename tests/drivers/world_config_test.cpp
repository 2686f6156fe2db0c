// station.yaml's `world:` section (drivers/station/world_config): the default, every form
// that is accepted, and bad input refused with the key named.
#include "drivers/station/world_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "daemon/daemon_config.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::station {
namespace {

using ::testing::HasSubstr;

class WorldConfigTest : public ::testing::Test {
protected:
    void SetUp() override {
        for (const char* n : {"a", "b", "c", "d"})
            std::ofstream(dir_.path() / (std::string(n) + ".json")) << "{}";
    }
    // The daemon's parser: the whole file, every problem at once.
    std::string problems(const std::string& world_yaml) {
        try {
            daemon::parse_daemon_config(sensors_ + world_yaml, "s.yaml", dir_.path());
        } catch (const ConfigError& e) {
            return e.what();
        }
        return "";
    }
    daemon::DaemonConfig parse(const std::string& world_yaml) {
        return daemon::parse_daemon_config(sensors_ + world_yaml, "s.yaml", dir_.path());
    }
    test::TempDir dir_{"worldcfg"};
    const std::string sensors_ =
        "root: b\nsensors:\n  - {name: a, udp_port: 7502, metadata: a.json}\n"
        "  - {name: b, udp_port: 7504, metadata: b.json}\n  - {name: c, udp_port: 7506, metadata: "
        "c.json}\n"
        "  - {name: d, udp_port: 7508, metadata: d.json}\n";
};

TEST_F(WorldConfigTest, RoadIsTheDefault) {
    const auto c = parse("");
    EXPECT_EQ(c.world.params.kind, core::WorldFrameKind::kRoad);
    EXPECT_EQ(c.world.params.root_sensor, 1u);
    EXPECT_EQ(c.world.frame_id, "utm");
    EXPECT_EQ(parse("world: {frame: sensor}\n").world.params.kind, core::WorldFrameKind::kSensor);
}

TEST_F(WorldConfigTest, GeoFromPositionsOrAGivenTransform) {
    const auto c = parse(
        "world:\n  frame: geo\n  frame_id: map_utm32\n  positions:\n"
        "    a: [691234.512, 5335012.331, 512.2]\n    c: [691260.0, 5335030.5, 512.9]\n"
        "    d: [691250, 5334990, 511]\n");
    ASSERT_EQ(c.world.params.kind, core::WorldFrameKind::kGeo);
    EXPECT_EQ(c.world.frame_id, "map_utm32");
    ASSERT_EQ(c.world.params.anchors.size(), 3u);
    EXPECT_EQ(c.world.params.anchors[1].sensor, 2u);
    EXPECT_DOUBLE_EQ(c.world.params.anchors[0].position_m.y(), 5335012.331);
    const auto g = parse(
        "world:\n  frame: geo\n  T_world_root: {translation: [691234.5, 5335012.3, 512], "
        "rotation_wxyz: [0.7071068, 0, 0, 0.7071068]}\n");
    ASSERT_TRUE(g.world.params.T_world_root.has_value());
    EXPECT_NEAR(g.world.params.T_world_root->translation().x(), 691234.5, 1e-9);
    // The same section through the file loader `lidarfuse fuse` uses.
    std::ofstream(dir_.path() / "w.yaml")
        << sensors_ << "world: {frame: geo, positions: {a: [0, 0, 0], "
        << "b: [10, 0, 0], c: [0, 10, 0]}}\n";
    const auto station = load_station_config(dir_.path() / "w.yaml");
    const auto w = load_world_config(dir_.path() / "w.yaml", station);
    EXPECT_EQ(w.params.anchors.size(), 3u);
    EXPECT_EQ(w.params.geo_average_frames, 100);  // the default: one sway period (5 s)
    EXPECT_EQ(parse("world: {frame: geo, average_frames: 20, positions: {a: [0, 0, 0], "
                    "b: [10, 0, 0], c: [0, 10, 0]}}\n")
                  .world.params.geo_average_frames,
              20);
}

TEST_F(WorldConfigTest, BadInputIsRefusedWithTheKeyNamed) {
    EXPECT_THAT(problems("world: {frame: utm}\n"),
                HasSubstr("world.frame: expected road, geo or sensor, got \"utm\""));
    EXPECT_THAT(problems("world: {frame: geo}\n"), HasSubstr("world.positions: missing"));
    EXPECT_THAT(problems("world: {frame: geo, positions: {a: [0, 0, 0], b: [1, 0, 0]}}\n"),
                HasSubstr("world.positions: expected at least 3 sensors, got 2"));
    EXPECT_THAT(
        problems("world: {frame: geo, positions: {a: [0, 0, 0], b: [1, 0, 0], x: [0, 1, 0]}}\n"),
        HasSubstr("world.positions.x: \"x\" is not the name of a configured sensor"));
    EXPECT_THAT(
        problems("world: {frame: geo, positions: {a: [0, 0, abc], b: [1, 0, 0], c: [0, 1, 0]}}\n"),
        HasSubstr("world.positions.a[2]: expected a number"));
    EXPECT_THAT(
        problems("world: {frame: geo, positions: {a: [0, 0], b: [1, 0, 0], c: [0, 1, 0]}}\n"),
        HasSubstr("world.positions.a: expected [x, y, z] in metres"));
    EXPECT_THAT(problems("world: {frame: geo, positions: [1, 2, 3]}\n"),
                HasSubstr("world.positions: expected a mapping of sensor name to [x, y, z]"));
    EXPECT_THAT(problems("world: {frame: road, positions: {a: [0, 0, 0]}}\n"),
                HasSubstr("world.positions: only used with world.frame: geo"));
    EXPECT_THAT(problems("world: {frame: geo, T_world_root: {translation: [1, 2, 3], "
                         "rotation_wxyz: [2, 0, 0, 0]}}\n"),
                HasSubstr("world.T_world_root.rotation_wxyz: expected a unit quaternion"));
    EXPECT_THAT(problems("world: {frame: geo, T_world_root: {translation: [1, 2]}}\n"),
                HasSubstr("world.T_world_root.translation: expected [x, y, z]"));
    EXPECT_THAT(problems("world: {frame: geo, average_frames: 0, positions: {a: [0, 0, 0], "
                         "b: [10, 0, 0], c: [0, 10, 0]}}\n"),
                HasSubstr("world.average_frames:"));
    EXPECT_THAT(problems("world: {frame: road, average_frames: 20}\n"),
                HasSubstr("world.average_frames: only used with world.frame: geo and positions"));
    EXPECT_THAT(problems("world: {frame: [road]}\n"), HasSubstr("world.frame:"));
    EXPECT_THAT(problems("world: road\n"), HasSubstr("world: expected a mapping"));
    EXPECT_THAT(problems("world: {frame: road, fram_id: x}\n"),
                HasSubstr("world.fram_id: unknown key"));
    EXPECT_THAT(
        problems("world: {frame: geo, frame_id: /utm, T_world_root: {translation: [0, 0, 0], "
                 "rotation_wxyz: [1, 0, 0, 0]}}\n"),
        HasSubstr("world.frame_id: expected 1..128 characters"));
}

TEST_F(WorldConfigTest, CollidingFrameNamesAreRefused) {
    const std::string geo =
        "  T_world_root: {translation: [0, 0, 0], rotation_wxyz: [1, 0, 0, 0]}\n";
    EXPECT_THAT(problems("world:\n  frame: geo\n  frame_id: c\n" + geo),
                HasSubstr("world.frame_id: \"c\" is also the name of sensors[2]"));
    EXPECT_THAT(
        problems("output: {dds: {frame_id: station}}\nworld:\n  frame: geo\n  frame_id: station\n" +
                 geo),
        HasSubstr("world.frame_id: \"station\" is also output.dds.frame_id"));
    // Not geo: the world frame is not published, so its name cannot collide.
    EXPECT_EQ(problems("world: {frame: road, frame_id: c}\n"), "");
}

}  // namespace
}  // namespace lidarfuse::station
