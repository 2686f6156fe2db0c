#include "daemon/daemon_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <string>
#include <vector>

#include "drivers/station/fusion_config.hpp"
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
    EXPECT_DOUBLE_EQ(c.network.receive_coalesce_ms, 5.0);
}

TEST_F(DaemonConfigTest, TheReceiversWaitIsReadAndChecked) {
    const auto c = parse_daemon_config(sensors_ + "network: {receive_coalesce_ms: 0.5}\n", "s.yaml",
                                       dir_.path());
    EXPECT_DOUBLE_EQ(c.network.receive_coalesce_ms, 0.5);
    const auto off = parse_daemon_config(sensors_ + "network: {receive_coalesce_ms: 0}\n", "s.yaml",
                                         dir_.path());
    EXPECT_DOUBLE_EQ(off.network.receive_coalesce_ms, 0.0);
    for (const char* bad : {"-1", "51", "soon"}) {
        try {
            parse_daemon_config(sensors_ + "network: {receive_coalesce_ms: " + bad + "}\n",
                                "s.yaml", dir_.path());
            ADD_FAILURE() << bad << " was accepted";
        } catch (const station::ConfigError& error) {
            EXPECT_THAT(error.what(), HasSubstr("network.receive_coalesce_ms")) << bad;
        }
    }
}

TEST_F(DaemonConfigTest, RecordIsOffByDefaultAndEveryKeyIsReadAndChecked) {
    const auto off = parse_daemon_config(sensors_, "s.yaml", dir_.path());
    EXPECT_FALSE(off.output.record.enabled);
    EXPECT_TRUE(
        off.output.record.directory.empty());  // <output.directory>/recordings, after --output
    const auto c = parse_daemon_config(sensors_ + R"(
output:
  record_clouds_format: pcd
  record: {enabled: true, directory: rec, max_file_mb: 64, max_file_s: 60, min_free_mb: 500,
           when_disk_low: stop, queue_mb: 32}
)",
                                       "s.yaml", dir_.path());
    EXPECT_EQ(off.output.record_clouds_format, OutputConfig::CloudFormat::kPly);
    EXPECT_TRUE(c.output.record.enabled);
    EXPECT_EQ(c.output.record_clouds_format, OutputConfig::CloudFormat::kPcd);
    EXPECT_EQ(c.output.record.directory, dir_.path() / "rec");
    EXPECT_DOUBLE_EQ(c.output.record.max_file_mb, 64.0);
    EXPECT_DOUBLE_EQ(c.output.record.max_file_s, 60.0);
    EXPECT_DOUBLE_EQ(c.output.record.min_free_mb, 500.0);
    EXPECT_EQ(c.output.record.when_disk_low, LowDiskPolicy::kStop);
    EXPECT_DOUBLE_EQ(c.output.record.queue_mb, 32.0);
    try {
        parse_daemon_config(sensors_ +
                                "output:\n  record_clouds_format: las\n"
                                "  record: {when_disk_low: pause, max_file_mb: 0, size: 3}\n",
                            "s.yaml", dir_.path());
        FAIL() << "no error";
    } catch (const station::ConfigError& error) {
        EXPECT_THAT(
            error.what(),
            HasSubstr(
                "output.record.when_disk_low: expected remove_oldest or stop, got \"pause\""));
        EXPECT_THAT(error.what(), HasSubstr("output.record.max_file_mb"));
        EXPECT_THAT(error.what(), HasSubstr("size"));
        EXPECT_THAT(error.what(),
                    HasSubstr("output.record_clouds_format: expected ply or pcd, got \"las\""));
    }
}

TEST_F(DaemonConfigTest, FramesArePredictedWhenBehindUnlessTheConfigSaysDrop) {
    EXPECT_TRUE(parse_daemon_config(sensors_, "s.yaml", dir_.path()).sync.predict_when_behind);
    const auto drop =
        parse_daemon_config(sensors_ + "sync: {when_behind: drop}\n", "s.yaml", dir_.path());
    EXPECT_FALSE(drop.sync.predict_when_behind);
    const auto predict =
        parse_daemon_config(sensors_ + "sync: {when_behind: predict}\n", "s.yaml", dir_.path());
    EXPECT_TRUE(predict.sync.predict_when_behind);
    try {
        parse_daemon_config(sensors_ + "sync: {when_behind: skip}\n", "s.yaml", dir_.path());
        FAIL() << "no error";
    } catch (const station::ConfigError& error) {
        EXPECT_THAT(error.what(),
                    HasSubstr("sync.when_behind: expected predict or drop, got \"skip\""));
    }
}

TEST_F(DaemonConfigTest, SensorClocksAreCheckedWithinASecondUnlessTheConfigSaysOtherwise) {
    EXPECT_DOUBLE_EQ(parse_daemon_config(sensors_, "s.yaml", dir_.path()).sync.max_clock_skew_ms,
                     1000.0);
    EXPECT_DOUBLE_EQ(
        parse_daemon_config(sensors_ + "sync: {max_clock_skew_ms: 0}\n", "s.yaml", dir_.path())
            .sync.max_clock_skew_ms,
        0.0);
    for (const char* bad : {"-1", "1e7", "soon"}) {
        try {
            parse_daemon_config(sensors_ + "sync: {max_clock_skew_ms: " + bad + "}\n", "s.yaml",
                                dir_.path());
            ADD_FAILURE() << bad << ": no error";
        } catch (const station::ConfigError& error) {
            EXPECT_THAT(error.what(), HasSubstr("sync.max_clock_skew_ms")) << bad;
        }
    }
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
sync: {deadline_ms: 40, queue_depth: 1}
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
    EXPECT_EQ(c.sync.queue_depth, 1);
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

TEST_F(DaemonConfigTest, DdsDefaultsAndKeys) {
    const auto defaults = parse_daemon_config(sensors_, "s.yaml", dir_.path());
    EXPECT_TRUE(defaults.output.dds.enabled);
    EXPECT_EQ(defaults.output.dds.domain_id, -1);  // ROS_DOMAIN_ID, else 0
    EXPECT_EQ(defaults.output.dds.topic_namespace, "lidarfuse");
    EXPECT_EQ(defaults.output.dds.frame_id, "lidarfuse/fused");  // no sensor name has a '/'
    EXPECT_EQ(defaults.output.stamp, StampSource::kSensor);
    EXPECT_EQ(defaults.output.dds.depth, 2);
    EXPECT_TRUE(defaults.output.dds.publish_points);
    EXPECT_EQ(defaults.output.dds.points_voxel_size_m, 0.0);  // no thinned cloud

    const auto c = parse_daemon_config(sensors_ + R"(
output:
  stamp: host
  dds: {enabled: false, domain_id: 42, namespace: site_7/fusion, frame_id: map, depth: 5,
        max_blocking_ms: 2, publish_points: false, points_voxel_size_m: 0.25,
        diagnostics_period_ms: 500}
)",
                                       "s.yaml", dir_.path());
    EXPECT_FALSE(c.output.dds.enabled);
    EXPECT_EQ(c.output.dds.domain_id, 42);
    EXPECT_EQ(c.output.dds.topic_namespace, "site_7/fusion");
    EXPECT_EQ(c.output.dds.frame_id, "map");
    EXPECT_EQ(c.output.dds.depth, 5);
    EXPECT_DOUBLE_EQ(c.output.dds.max_blocking_ms, 2.0);
    EXPECT_FALSE(c.output.dds.publish_points);
    EXPECT_DOUBLE_EQ(c.output.dds.points_voxel_size_m, 0.25);
    EXPECT_DOUBLE_EQ(c.output.dds.diagnostics_period_ms, 500.0);
    for (const char* bad : {"-0.5", "101", "fine"}) {
        try {
            parse_daemon_config(sensors_ + "output: {dds: {points_voxel_size_m: " + bad + "}}\n",
                                "s.yaml", dir_.path());
            FAIL() << bad;
        } catch (const station::ConfigError& error) {
            EXPECT_THAT(error.what(), HasSubstr("output.dds.points_voxel_size_m")) << bad;
        }
    }
    EXPECT_EQ(c.output.stamp, StampSource::kHost);
}

// tf2 gives a frame one parent: a fused frame named after a sensor would make that sensor
// its own parent and drop it from tf. Refused, naming the key and the sensor.
TEST_F(DaemonConfigTest, FrameNamesThatCollideOrTf2RefusesAreRefused) {
    try {
        parse_daemon_config(sensors_ + "output: {stamp: gps, dds: {frame_id: a}}\n", "s.yaml",
                            dir_.path());
        FAIL();
    } catch (const station::ConfigError& error) {
        const std::string text = error.what();
        EXPECT_THAT(text, HasSubstr("output.dds.frame_id: \"a\" is also the name of sensors[0]"));
        EXPECT_THAT(text, HasSubstr("output.stamp: expected sensor or host, got \"gps\""));
        EXPECT_EQ(error.problems().size(), 2u);
    }
    for (const char* bad : {"/map", "a b", ""}) {
        EXPECT_THROW(parse_daemon_config(sensors_ + "output: {dds: {frame_id: \"" + bad + "\"}}\n",
                                         "s.yaml", dir_.path()),
                     station::ConfigError)
            << bad;
    }
    EXPECT_NO_THROW(parse_daemon_config(sensors_ + "output: {dds: {frame_id: site_7/fused}}\n",
                                        "s.yaml", dir_.path()));
}

// A station's frames carry output.dds.frame_prefix, so that stations sharing a domain keep
// their tf trees apart; a segment daemon names the frame of a station's clouds
// (source.dds.frame_id), which becomes that sensor's tf frame: station0's tree then hangs
// below the segment's fused frame.
TEST_F(DaemonConfigTest, AFramePrefixKeepsStationsApartAndADdsSourceNamesItsFrame) {
    const auto station =
        parse_daemon_config(sensors_ + "  - {name: b, udp_port: 7504, metadata: a.json}\n" +
                                "output: {dds: {frame_prefix: station0/, frame_id: road}}\n",
                            "s.yaml", dir_.path());
    EXPECT_EQ(station.output.dds.frame_prefix, "station0/");
    EXPECT_EQ(fused_frame_of(station.output.dds), "station0/road");
    EXPECT_EQ(sensor_frames_of(station.station, station.output.dds),
              (std::vector<std::string>{"station0/a", "station0/b"}));
    EXPECT_EQ(fused_frame_of(parse_daemon_config(sensors_, "s.yaml", dir_.path()).output.dds),
              "lidarfuse/fused");  // no prefix by default

    const std::string segment_sensors =
        "root: station0\nsensors:\n"
        "  - {name: station0, source: {dds: {topic: rt/station0/points, frame_id: "
        "station0/road}}}\n"
        "  - {name: station1, source: {dds: {topic: rt/station1/points}}}\n";
    const auto segment = parse_daemon_config(
        segment_sensors + "output: {dds: {frame_id: segment}}\n", "s.yaml", dir_.path());
    EXPECT_EQ(segment.station.sensors[0].dds->frame_id.value_or(""), "station0/road");
    EXPECT_FALSE(segment.station.sensors[1].dds->frame_id);  // the first cloud's frame is kept
    EXPECT_EQ(sensor_frames_of(segment.station, segment.output.dds),
              (std::vector<std::string>{"station0/road", "station1"}));

    const auto problems_of = [&](const std::string& yaml) {
        try {
            parse_daemon_config(yaml, "s.yaml", dir_.path());
        } catch (const station::ConfigError& error) {
            return error.problems();
        }
        return std::vector<std::string>{};
    };
    // The segment's own fused frame, a frame another sensor has, characters tf2 refuses.
    EXPECT_THAT(problems_of(segment_sensors + "output: {dds: {frame_id: station0/road}}\n"),
                ::testing::ElementsAre(
                    "output.dds.frame_id: \"station0/road\" is also sensors[0].source.dds."
                    "frame_id; pick a name no sensor has (the default, lidarfuse/fused, cannot "
                    "collide)"));
    EXPECT_THAT(
        problems_of("root: a\n" + sensors_ +
                    "  - {name: b, source: {dds: {topic: rt/b/points, frame_id: a}}}\n"),
        ::testing::ElementsAre("sensors[1]: its tf frame \"a\" is also sensors[0]'s; "
                               "each sensor needs a frame of its own (source.dds.frame_id)"));
    EXPECT_THAT(problems_of(sensors_ +
                            "  - {name: b, source: {dds: {topic: rt/b/points, frame_id: /b}}}\n"),
                ::testing::ElementsAre(HasSubstr(
                    "sensors[1].source.dds.frame_id: expected 1..128 characters of "
                    "[A-Za-z0-9_./-], not starting with '/' (tf2 refuses a leading slash), got "
                    "\"/b\"")));
    EXPECT_THAT(problems_of(sensors_ + "output: {dds: {frame_prefix: \"/s\"}}\n"),
                ::testing::ElementsAre(HasSubstr("output.dds.frame_prefix: expected 1..128")));
    EXPECT_THAT(
        problems_of(sensors_ + "output: {dds: {frame_prefix: " + std::string(120, 's') + "}}\n"),
        ::testing::ElementsAre(HasSubstr("longer than tf's 128 characters")));
    EXPECT_TRUE(problems_of(sensors_ + "output: {dds: {frame_prefix: \"\"}}\n").empty());
}

TEST_F(DaemonConfigTest, EveryDdsProblemIsListed) {
    try {
        parse_daemon_config(sensors_ + R"(
output:
  dds: {domain_id: 233, namespace: /bad//name, depth: 0, max_blocking_ms: -1, publish_point: true,
        enabled: maybe}
)",
                            "bad.yaml", dir_.path());
        FAIL();
    } catch (const station::ConfigError& error) {
        const std::string text = error.what();
        EXPECT_THAT(text, HasSubstr("output.dds.domain_id"));
        EXPECT_THAT(text, HasSubstr("output.dds.namespace: expected ROS name segments"));
        EXPECT_THAT(text, HasSubstr("output.dds.depth"));
        EXPECT_THAT(text, HasSubstr("output.dds.max_blocking_ms"));
        EXPECT_THAT(text, HasSubstr("output.dds.publish_point: unknown key"));
        EXPECT_THAT(text, HasSubstr("output.dds.enabled"));
        EXPECT_EQ(error.problems().size(), 6u);
    }
    for (const char* bad : {"1abc", "a/", "a b", "a//b"}) {
        EXPECT_THROW(parse_daemon_config(sensors_ + "output: {dds: {namespace: \"" + bad + "\"}}\n",
                                         "s.yaml", dir_.path()),
                     station::ConfigError)
            << bad;
    }
    EXPECT_NO_THROW(parse_daemon_config(sensors_ + "output: {dds: {namespace: \"\"}}\n", "s.yaml",
                                        dir_.path()));
}

TEST_F(DaemonConfigTest, FoxgloveIsOffByDefaultAndEveryKeyIsRead) {
    const auto defaults = parse_daemon_config(sensors_, "s.yaml", dir_.path());
    EXPECT_FALSE(defaults.output.foxglove.enabled);
    EXPECT_EQ(defaults.output.foxglove.bind_address, "127.0.0.1");  // this host only
    EXPECT_EQ(defaults.output.foxglove.port, 8765);
    EXPECT_EQ(defaults.output.foxglove.max_clients, 8);
    EXPECT_DOUBLE_EQ(defaults.output.foxglove.client_buffer_mb, 16.0);
    const auto c = parse_daemon_config(sensors_ + R"(
output:
  foxglove: {enabled: true, bind_address: 0.0.0.0, port: 9090, max_clients: 2,
             client_buffer_mb: 4.5}
)",
                                       "s.yaml", dir_.path());
    EXPECT_TRUE(c.output.foxglove.enabled);
    EXPECT_EQ(c.output.foxglove.bind_address, "0.0.0.0");
    EXPECT_EQ(c.output.foxglove.port, 9090);
    EXPECT_EQ(c.output.foxglove.max_clients, 2);
    EXPECT_DOUBLE_EQ(c.output.foxglove.client_buffer_mb, 4.5);
    // 0: any free port (the daemon logs the one it got).
    EXPECT_EQ(
        parse_daemon_config(sensors_ + "output: {foxglove: {port: 0}}\n", "s.yaml", dir_.path())
            .output.foxglove.port,
        0);
}

TEST_F(DaemonConfigTest, EveryFoxgloveProblemIsListedWithItsKey) {
    try {
        parse_daemon_config(sensors_ + R"(
output:
  foxglove: {enabled: yes please, bind_address: localhost, port: 70000, max_clients: 0,
             client_buffer_mb: 0, clients: 3}
)",
                            "bad.yaml", dir_.path());
        FAIL() << "no error";
    } catch (const station::ConfigError& error) {
        const std::string text = error.what();
        for (const char* expected :
             {"output.foxglove.enabled", "output.foxglove.port", "output.foxglove.max_clients",
              "output.foxglove.client_buffer_mb", "output.foxglove.clients: unknown key",
              "output.foxglove.bind_address: expected an IPv4 address such as 127.0.0.1 or "
              "0.0.0.0, got \"localhost\""}) {
            EXPECT_THAT(text, HasSubstr(expected));
        }
        EXPECT_EQ(error.problems().size(), 6u) << text;
    }
    EXPECT_THROW(parse_daemon_config(sensors_ + "output: {foxglove: [1]}\n", "s.yaml", dir_.path()),
                 station::ConfigError);
}

// The live view sends the DDS samples' CDR bytes: without DDS it would have nothing to send.
TEST_F(DaemonConfigTest, FoxgloveWithoutDdsIsRefused) {
    try {
        parse_daemon_config(
            sensors_ + "output: {dds: {enabled: false}, foxglove: {enabled: true}}\n", "s.yaml",
            dir_.path());
        FAIL() << "no error";
    } catch (const station::ConfigError& error) {
        EXPECT_THAT(error.what(), HasSubstr("output.foxglove.enabled: needs output.dds.enabled"));
        EXPECT_EQ(error.problems().size(), 1u);
    }
    EXPECT_NO_THROW(parse_daemon_config(
        sensors_ + "output: {dds: {enabled: false}, foxglove: {enabled: false}}\n", "s.yaml",
        dir_.path()));
}

// A recording keeps Ouster datagrams: a station with a DDS source cannot record.
TEST_F(DaemonConfigTest, RecordingWithADdsSourceIsRefused) {
    const std::string sensors = sensors_ +
                                "  - {name: station1, source: {dds: {topic: "
                                "rt/station1/lidarfuse/points}}}\n";
    try {
        parse_daemon_config(sensors + "output: {record: {enabled: true}}\n", "s.yaml", dir_.path());
        FAIL() << "no error";
    } catch (const station::ConfigError& error) {
        EXPECT_THAT(error.what(), HasSubstr("output.record.enabled: records Ouster packets, and "
                                            "sensors[1] (\"station1\") takes its clouds from DDS"));
        EXPECT_EQ(error.problems().size(), 1u);
    }
    const auto c = parse_daemon_config(sensors, "s.yaml", dir_.path());
    ASSERT_TRUE(c.station.sensors[1].dds);
    EXPECT_EQ(c.station.sensors[1].dds->topic, "rt/station1/lidarfuse/points");
}

// config/station.example.yaml says it lists every key with its default: its registration
// and dynamics sections read back as exactly lidarfused's defaults.
TEST(DaemonConfigExample, RegistrationAndDynamicsHoldTheDefaults) {
    const core::FusionParams d = DaemonConfig().fusion;
    const core::FusionParams e =
        station::load_fusion_params(test::source_dir() / "config" / "station.example.yaml");
    EXPECT_EQ(e.voxel_size_m, d.voxel_size_m);
    EXPECT_EQ(e.window_frames, d.window_frames);
    EXPECT_EQ(e.covariance_neighbors, d.covariance_neighbors);
    EXPECT_EQ(e.correspondence_factor, d.correspondence_factor);
    EXPECT_EQ(e.huber_delta, d.huber_delta);
    EXPECT_EQ(e.deskew, d.deskew);
    EXPECT_EQ(e.min_fitness, d.min_fitness);
    EXPECT_EQ(e.max_jump_m, d.max_jump_m);
    EXPECT_EQ(e.max_jump_deg, d.max_jump_deg);
    EXPECT_EQ(e.divergence_frames, d.divergence_frames);
    EXPECT_EQ(e.retry_interval_frames, d.retry_interval_frames);
    EXPECT_EQ(e.num_threads, d.num_threads);
    EXPECT_EQ(e.initial.features.octree.max_voxel_size_m,
              d.initial.features.octree.max_voxel_size_m);
    EXPECT_EQ(e.initial.features.octree.min_voxel_size_m,
              d.initial.features.octree.min_voxel_size_m);
    EXPECT_EQ(e.initial.pair.ransac.max_iterations, d.initial.pair.ransac.max_iterations);
    EXPECT_EQ(e.initial.pair.ransac.inlier_threshold_m, d.initial.pair.ransac.inlier_threshold_m);
    EXPECT_EQ(e.initial.pair.p2p_cutoff_m, d.initial.pair.p2p_cutoff_m);
    EXPECT_EQ(e.initial.pair.ransac.seed, d.initial.pair.ransac.seed);
    EXPECT_EQ(e.remove_dynamic, d.remove_dynamic);
    EXPECT_EQ(e.background.attenuation, d.background.attenuation);
    EXPECT_EQ(e.background.change.range_threshold_m, d.background.change.range_threshold_m);
    EXPECT_EQ(e.background.dynamic_threshold, d.background.dynamic_threshold);
    EXPECT_EQ(e.background.voxel_size_m, d.background.voxel_size_m);
    EXPECT_EQ(e.background.change.cone_bins, d.background.change.cone_bins);
}

// The example states the sync section's defaults, the frame queue's depth among them.
TEST(DaemonConfigExample, SyncHoldsTheDefaults) {
    const YAML::Node sync =
        YAML::LoadFile((test::source_dir() / "config" / "station.example.yaml").string())["sync"];
    const SyncConfig d = DaemonConfig().sync;
    EXPECT_EQ(d.queue_depth, 2);
    EXPECT_EQ(sync["queue_depth"].as<int>(), d.queue_depth);
    EXPECT_EQ(sync["deadline_ms"].as<double>(), d.deadline_ms);
    EXPECT_EQ(sync["reset_jump_ms"].as<double>(), d.reset_jump_ms);
    EXPECT_EQ(sync["max_clock_skew_ms"].as<double>(), d.max_clock_skew_ms);
    EXPECT_EQ(sync["when_behind"].as<std::string>() == "predict", d.predict_when_behind);
}

}  // namespace
}  // namespace lidarfuse::daemon
