// Sensors whose scans are PointCloud2 clouds on DDS (station.yaml source.dds,
// daemon/dds_input.hpp), against real Cyclone writers on loopback: each readable cloud
// becomes a scan with its stamp and points, bad ones are refused and counted, and a
// Pipeline whose sensors are all DDS topics registers and fuses them like Ouster sensors.
#include "daemon/dds_input.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "daemon/dds_messages.hpp"
#include "daemon/pipeline.hpp"
#include "daemon/status_line.hpp"
#include "drivers/capture/station_capture.hpp"
#include "tests/daemon/dds_sources.hpp"
#include "tests/daemon/dds_test_support.hpp"
#include "tests/daemon/lidarfused_test_support.hpp"

namespace lidarfuse::daemon {
namespace {

namespace fs = std::filesystem;
using dds_sources::CloudWriters;
using dds_sources::DriverTopics;
using dds_sources::settled_stats;

core::FusedCloud line_cloud(int n, float y) {
    core::FusedCloud c;
    for (int i = 0; i < n; ++i) {
        c.points.emplace_back(0.5f * static_cast<float>(i), y, -1.0f);
        c.intensity.push_back(1.0f);
        c.sensor.push_back(0);
        c.dynamic.push_back(0);
    }
    return c;
}

constexpr std::int64_t kT0 = 1'763'700'000'000'000'000;
// A 20 Hz publisher that dropped three frames (a station whose fusion fell behind).
constexpr std::int64_t kStampMs[6] = {0, 50, 100, 200, 250, 400};

// Opens `topic`'s writer and waits until `input` has matched it.
void open_for(CloudWriters* writers, const DdsInput& input, const std::string& topic) {
    ASSERT_TRUE(writers->ok());
    ASSERT_TRUE(writers->open(topic));
    ASSERT_TRUE(test::eventually([&] { return input.status().publishers > 0; }));
}

// One cloud, then a wait until `input` has taken it: a burst beyond the reader's keep-last
// depth would replace the oldest.
void send_one(CloudWriters* writers, const DdsInput& input, const std::string& topic,
              const std::string& frame, const core::FusedCloud& c, std::int64_t t_ns) {
    const std::uint64_t before = input.status().clouds;
    ASSERT_TRUE(writers->write(topic, frame, c, t_ns));
    ASSERT_TRUE(test::eventually([&] { return input.status().clouds == before + 1; }));
}

TEST(DdsInput, CloudsBecomeScansAndBadOnesAreRefusedAndCounted) {
    test::use_loopback_dds();
    const int domain = test::unique_domain_id();
    SensorIngest sensor;
    sensor.index = 3;
    sensor.name = "station1";
    sensor.time_offset_ns = -1000;
    const std::string topic = "rt/station1/points";
    DdsInput input(&sensor, {topic, domain, std::nullopt}, spdlog::default_logger());
    EXPECT_TRUE(sensor.metadata_known.load());  // nothing to wait for
    EXPECT_EQ(input.sensor_index(), 3u);
    input.start();
    CloudWriters writers(domain);
    ASSERT_NO_FATAL_FAILURE(open_for(&writers, input, topic));
    const auto send = [&](const std::string& frame, const core::FusedCloud& c, std::int64_t t) {
        send_one(&writers, input, topic, frame, c, t);
    };
    for (int f = 0; f < 6; ++f) {
        ASSERT_NO_FATAL_FAILURE(send("road", line_cloud(10 + f, static_cast<float>(f)),
                                     kT0 + kStampMs[f] * 1'000'000LL));
    }
    // Refused: no time, another frame, no finite point.
    ASSERT_NO_FATAL_FAILURE(send("road", line_cloud(20, 9.0f), 0));
    ASSERT_NO_FATAL_FAILURE(send("lidar0", line_cloud(20, 9.0f), kT0 + 600'000'000LL));
    core::FusedCloud holes = line_cloud(4, 9.0f);
    for (auto& p : holes.points) p.z() = std::numeric_limits<float>::quiet_NaN();
    ASSERT_NO_FATAL_FAILURE(send("road", holes, kT0 + 650'000'000LL));
    input.stop();
    const DdsInputStatus status = input.status();
    EXPECT_EQ(status.topic, topic);
    EXPECT_EQ(status.domain_id, domain);
    EXPECT_EQ(status.publishers, 1);
    EXPECT_EQ(status.refused, 3u);
    EXPECT_EQ(status.non_finite_points, 4u);
    EXPECT_EQ(status.frame_id, "road");
    EXPECT_THAT(status.last_error, ::testing::HasSubstr("sensor \"station1\" (" + topic + ")"));
    EXPECT_EQ(sensor.scans.load(), 6u);
    EXPECT_EQ(sensor.scans_rejected.load(), 3u);
    EXPECT_EQ(sensor.frames_per_second.load(), 20);  // the shortest period, not the mean (12.5 Hz)
    EXPECT_EQ(sensor.clock_offset_ns.load() < 0, true);  // 2025 stamps, read in 2026 or later
    for (int f = 0; f < 6; ++f) {
        const auto m = input.queue().try_pop();
        ASSERT_TRUE(m) << f;
        EXPECT_EQ(m->sensor, 3u);
        EXPECT_EQ(m->t_ns, kT0 + kStampMs[f] * 1'000'000LL - 1000);
        ASSERT_EQ(m->points.size(), static_cast<std::size_t>(10 + f));
        EXPECT_EQ(m->points[2], Eigen::Vector3f(1.0f, static_cast<float>(f), -1.0f));
        EXPECT_TRUE(m->point_dt_s.empty());  // no per-point times: no deskew
        EXPECT_GT(m->complete_steady_ns, 0);
    }
    EXPECT_FALSE(input.queue().try_pop());
}

// With source.dds.frame_id, the frame is known before any cloud: one in another frame is
// refused even when it comes first (a station started with the wrong frame_prefix).
TEST(DdsInput, AConfiguredFrameIsTheOnlyOneTakenFromTheFirstCloudOn) {
    test::use_loopback_dds();
    const int domain = test::unique_domain_id();
    SensorIngest sensor;
    sensor.name = "station0";
    const std::string topic = "rt/station0/points";
    DdsInput input(&sensor, {topic, domain, std::string("station0/road")},
                   spdlog::default_logger());
    EXPECT_EQ(input.status().frame_id, "station0/road");
    input.start();
    CloudWriters writers(domain);
    ASSERT_NO_FATAL_FAILURE(open_for(&writers, input, topic));
    std::int64_t t_ns = kT0;
    for (const char* frame : {"road", "station0/road", "road", "station0/road"}) {
        ASSERT_NO_FATAL_FAILURE(
            send_one(&writers, input, topic, frame, line_cloud(10, 1.0f), t_ns));
        t_ns += 50'000'000LL;
    }
    input.stop();
    const DdsInputStatus status = input.status();
    EXPECT_EQ(status.refused, 2u);
    EXPECT_EQ(sensor.scans.load(), 2u);
    EXPECT_EQ(status.frame_id, "station0/road");
    EXPECT_THAT(status.last_error,
                ::testing::HasSubstr(
                    "frame_id \"road\", expected \"station0/road\" (source.dds.frame_id)"));
}

// A sensor fed by this daemon's own cloud topic would register the fused cloud against
// itself: refused at start, naming the sensor and the topic.
TEST(DdsInputPipeline, TheDaemonsOwnCloudTopicIsRefusedAsASource) {
    test::use_loopback_dds();
    test::TempDir dir("ddsloop");
    const int domain = test::unique_domain_id();
    for (const char* leaf : {"points", "points_voxel"}) {
        std::ofstream(dir.path() / "station.yaml")
            << "sensors:\n  - {name: self, source: {dds: {topic: rt/seg" << domain << "/" << leaf
            << ", domain_id: " << domain
            << "}}}\noutput: {directory: " << (dir.path() / "out").string()
            << ", dds: {domain_id: " << domain << ", namespace: seg" << domain << "}}\n";
        const DaemonConfig config = load_daemon_config(dir.path() / "station.yaml");
        try {
            Pipeline pipeline(config);
            FAIL() << leaf << ": no error";
        } catch (const std::runtime_error& error) {
            EXPECT_THAT(error.what(),
                        ::testing::HasSubstr("sensors[0] (\"self\"): source.dds.topic rt/seg" +
                                             std::to_string(domain) + "/" + leaf +
                                             " is this daemon's own output"));
        }
    }
}

// A station whose two sensors are ROS 2 driver topics: lidarfused registers them from
// nothing and tracks them as it would Ouster sensors. Without per-point times there is no
// deskew, so the bound is looser than an Ouster station's (1.5 cm strict in the daemon's
// replay tests); measured 0.7 cm / 0.05 deg over 5 s.
TEST(DdsInputPipeline, SensorsFromDdsTopicsAreRegisteredAndFused) {
    test::use_loopback_dds();
    test::TempDir dir("ddsin");
    DriverTopics drivers(dir.path(), "ddsin");
    ASSERT_NO_FATAL_FAILURE(drivers.simulate());
    const fs::path sim = drivers.sim();
    std::ofstream(dir.path() / "station.yaml")
        << "station: ros-drivers\nsensors:\n"
        << drivers.sensors_yaml() << "world: {frame: sensor}\n"
        << "output: {directory: " << (dir.path() / "out").string() << ", dds: {enabled: false}}\n";
    const DaemonConfig config = load_daemon_config(dir.path() / "station.yaml");
    Pipeline pipeline(config);
    pipeline.start();
    ASSERT_NO_FATAL_FAILURE(drivers.open_for(&pipeline));
    EXPECT_EQ(drivers.publish(), 200u);  // 2 sensors x 5 s x 20 Hz
    // Fusion catches up (the initial registration ran beside it); then the pipeline stops.
    const PipelineStats stats = settled_stats(&pipeline);
    pipeline.stop();
    for (std::size_t s = 0; s < 2; ++s) {
        ASSERT_TRUE(stats.sensors[s].dds);
        // The reader keeps the last 8 clouds: on a loaded machine (a parallel ctest) its
        // thread can be late long enough to lose one, by design. Every cloud taken is a scan.
        EXPECT_GE(stats.sensors[s].dds->clouds, 90u) << s;
        EXPECT_LE(stats.sensors[s].dds->clouds, 100u) << s;
        EXPECT_EQ(stats.sensors[s].dds->refused, 0u) << s;
        EXPECT_EQ(stats.sensors[s].dds->frame_id, stats.sensors[s].name);
        EXPECT_EQ(stats.sensors[s].scans, stats.sensors[s].dds->clouds) << s;
    }
    if (!stats.sensors[1].pose_valid) {
        // Under the sanitizers the initial registration can outlast the 5 s of clouds.
        GTEST_SKIP() << "the initial registration did not finish within the run ("
                     << stats.frames_fused << " frames fused): a loaded machine or a sanitizer";
    }
    EXPECT_TRUE(stats.sensors[0].pose_valid);
    EXPECT_GE(stats.frames_synchronised, 85u);
    std::printf("ROS 2 driver topics: %llu frames synchronised, %llu fused\n",
                static_cast<unsigned long long>(stats.frames_synchronised),
                static_cast<unsigned long long>(stats.frames_fused));
    std::string eval;
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " +
                                    (sim / "ground_truth.csv").string() + " --poses " +
                                    (dir.path() / "out" / "poses.csv").string() + " --root lidar0",
                                &eval),
              0)
        << eval;
    const double strict_m =
        std::stod(test::line_after(eval, "eval_mean_strict_rmse_trans ").value_or("1e9"));
    const double strict_deg =
        std::stod(test::line_after(eval, "eval_mean_strict_rmse_rot ").value_or("1e9"));
    std::printf("strict RMSE against the truth: %.2f cm / %.4f deg\n", strict_m * 100, strict_deg);
    EXPECT_LE(strict_m, 0.02) << eval;
    EXPECT_LE(strict_deg, 0.1) << eval;
}

// A street corner as a sensor sees it (its frame, metres): a floor and two walls, enough for
// the root's track.
core::FusedCloud corner_cloud() {
    core::FusedCloud c;
    const auto add = [&](float x, float y, float z) {
        c.points.emplace_back(x, y, z);
        c.intensity.push_back(1.0f);
        c.sensor.push_back(0);
        c.dynamic.push_back(0);
    };
    for (int i = 0; i < 40; ++i) {
        for (int j = 0; j < 40; ++j) {
            const float u = 0.5f * static_cast<float>(i), v = 0.25f * static_cast<float>(j);
            add(u - 5.0f, v - 5.0f, -2.0f);         // floor
            add(u - 5.0f, 6.0f, v * 0.5f - 2.0f);   // wall ahead
            add(8.0f, v - 5.0f, u * 0.25f - 2.0f);  // wall to the side
        }
    }
    return c;
}

// A station whose sources disagree about the time: the root on time, one source 1.5 s ahead
// and one 5 s behind (clocks not synchronised). Without the clock check
// (sync.max_clock_skew_ms: 0) the synchroniser's frames jumped by seconds back and forth,
// every sensor was reported OK, and the root was not registered in a single frame (poses.csv
// had no row of it). With it the root is synchronised and registered at every frame, and the
// others' scans are refused, counted and reported CLOCK_SKEW with their skew.
TEST(DdsInputPipeline, SourcesWhoseClocksAreOffBySecondsAreRefusedWhileTheRootIsFused) {
    test::use_loopback_dds();
    test::TempDir dir("ddsclock");
    const int domain = test::unique_domain_id();
    const std::string prefix = "rt/ddsclock" + std::to_string(domain) + "/";
    const char* names[3] = {"root", "ahead", "behind"};
    const std::int64_t skew_ns[3] = {0, 1'500'000'000, -5'000'000'000};
    std::ofstream yaml(dir.path() / "station.yaml");
    yaml << "station: clocks\nsensors:\n";
    for (const char* name : names) {
        yaml << "  - {name: " << name << ", source: {dds: {topic: " << prefix << name
             << "/points, domain_id: " << domain << "}}}\n";
    }
    yaml << "world: {frame: sensor}\noutput: {directory: " << (dir.path() / "out").string()
         << ", dds: {enabled: false}}\n";
    yaml.close();
    Pipeline pipeline(load_daemon_config(dir.path() / "station.yaml"));
    pipeline.start();
    CloudWriters writers(domain);
    ASSERT_TRUE(writers.ok());
    for (const char* name : names) ASSERT_TRUE(writers.open(prefix + name + "/points"));
    ASSERT_TRUE(test::eventually([&] {
        const auto stats = pipeline.stats();
        bool matched = true;
        for (const auto& sensor : stats.sensors) matched = matched && sensor.dds->publishers > 0;
        return matched;
    }));
    constexpr int kFrames = 40;
    const core::FusedCloud cloud = corner_cloud();
    const std::int64_t t0 = realtime_ns();
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < kFrames; ++k) {
        std::this_thread::sleep_until(start + std::chrono::milliseconds(50 * k));
        for (int s = 0; s < 3; ++s) {
            ASSERT_TRUE(writers.write(prefix + names[s] + "/points", names[s], cloud,
                                      t0 + 50'000'000LL * k + skew_ns[s]));
        }
    }
    // Every cloud taken has become a scan or a refusal, and fusion has caught up.
    const PipelineStats stats = settled_stats(&pipeline);
    pipeline.stop();
    const std::string line = status_line(stats);
    std::printf("clocks: %s; %llu synchronised, %llu late\n", line.c_str(),
                static_cast<unsigned long long>(stats.frames_synchronised),
                static_cast<unsigned long long>(stats.scans_late));
    const auto& root = stats.sensors[0];
    EXPECT_EQ(root.scans_off_clock, 0u);
    EXPECT_EQ(root.state, SensorState::kOk);
    // The reader keeps its last 8 clouds: a loaded machine may lose one, by design.
    EXPECT_GE(root.scans, kFrames - 4u);
    for (int s = 1; s < 3; ++s) {
        const auto& off = stats.sensors[static_cast<std::size_t>(s)];
        // A scan that came before the root's first has nothing to be compared with.
        EXPECT_GE(off.scans_off_clock + 2, off.scans) << off.name;
        EXPECT_GE(off.scans_off_clock, kFrames - 6u) << off.name;
        EXPECT_EQ(off.state, SensorState::kClockSkew) << off.name;
        // The skew is the clocks' difference and the sources' delivery latencies' (ms here).
        EXPECT_NEAR(off.clock_skew_ms, static_cast<double>(skew_ns[s]) * 1e-6, 100.0) << off.name;
    }
    EXPECT_THAT(line, ::testing::HasSubstr("2 CLOCK_SKEW"));
    // The line's seconds carry the same delivery latencies as the figure: 4.99 s is as
    // right as 5.00 s (a loaded machine printed "behind: clock 4.998 s").
    const std::optional<std::string> ahead = test::line_after(line, "ahead: clock ");
    const std::optional<std::string> behind = test::line_after(line, "behind: clock ");
    ASSERT_TRUE(ahead && behind) << line;
    EXPECT_NEAR(std::stod(*ahead), 1.5, 0.1) << line;
    EXPECT_NEAR(std::stod(*behind), 5.0, 0.1) << line;
    EXPECT_THAT(*ahead, ::testing::MatchesRegex("[0-9.]+ s ahead of the root's.*")) << line;
    EXPECT_THAT(*behind, ::testing::MatchesRegex("[0-9.]+ s behind the root's.*")) << line;
    // The root went on: in a frame of its own every time, none of its scans late, and
    // registered (poses.csv has its row) in every frame fused.
    EXPECT_LE(stats.scans_late, 1u);
    // (The last frame may still wait for its deadline when the figures are taken.)
    EXPECT_GE(stats.frames_synchronised, root.scans - 2);
    std::size_t root_rows = 0;
    for (const auto& r : io::read_pose_csv(dir.path() / "out" / "poses.csv"))
        root_rows += r.sensor == "root" ? 1 : 0;
    // Fusion takes as many of those frames as the machine allows (a loaded one drops some).
    EXPECT_GT(root_rows, 0u);
    EXPECT_GE(root_rows + 1, stats.frames_fused - stats.frames_predicted);
}

// A source that floods its topic (clouds as fast as its writer can send them, each stamped
// when it is sent) beside a root at 20 Hz: the flood's surplus is dropped oldest-first in
// its reader and its scan queue and counted, the root's scans all become frames, fusion goes
// on, and the pipeline stops promptly: never a stalled pipeline.
TEST(DdsInputPipeline, AFloodOfCloudsIsDroppedAndCountedWhileTheRootKeepsBeingFused) {
    test::use_loopback_dds();
    test::TempDir dir("ddsflood");
    const int domain = test::unique_domain_id();
    const std::string prefix = "rt/ddsflood" + std::to_string(domain) + "/";
    std::ofstream(dir.path() / "station.yaml")
        << "station: flood\nsensors:\n"
        << "  - {name: root, source: {dds: {topic: " << prefix
        << "root/points, domain_id: " << domain << "}}}\n"
        << "  - {name: flood, source: {dds: {topic: " << prefix
        << "flood/points, domain_id: " << domain << "}}}\n"
        << "world: {frame: sensor}\noutput: {directory: " << (dir.path() / "out").string()
        << ", dds: {enabled: false}}\n";
    Pipeline pipeline(load_daemon_config(dir.path() / "station.yaml"));
    pipeline.start();
    CloudWriters root_writer(domain), flood_writer(domain);
    ASSERT_TRUE(root_writer.ok() && flood_writer.ok());
    ASSERT_TRUE(root_writer.open(prefix + "root/points"));
    ASSERT_TRUE(flood_writer.open(prefix + "flood/points"));
    ASSERT_TRUE(test::eventually([&] {
        const auto stats = pipeline.stats();
        return stats.sensors[0].dds->publishers > 0 && stats.sensors[1].dds->publishers > 0;
    }));
    const core::FusedCloud cloud = corner_cloud();
    const std::int64_t t0 = realtime_ns();
    const auto start = std::chrono::steady_clock::now();
    constexpr int kFrames = 40;  // 2 s at 20 Hz, stamped as the time passes
    std::atomic<bool> done{false};
    std::uint64_t flooded = 0;
    std::thread flood([&] {
        // Each stamped when it is sent, on the clock the root's stamps follow.
        while (!done.load()) {
            flood_writer.write(prefix + "flood/points", "flood", cloud, realtime_ns());
            ++flooded;
        }
    });
    for (int k = 0; k < kFrames; ++k) {
        std::this_thread::sleep_until(start + std::chrono::milliseconds(50 * k));
        ASSERT_TRUE(
            root_writer.write(prefix + "root/points", "root", cloud, t0 + 50'000'000LL * k));
    }
    done.store(true);
    flood.join();
    const PipelineStats stats = settled_stats(&pipeline);
    const auto stop_started = std::chrono::steady_clock::now();
    pipeline.stop();
    const double stop_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - stop_started).count();
    const auto& root = stats.sensors[0];
    const auto& flood_sensor = stats.sensors[1];
    std::printf(
        "flood: %llu clouds written, %llu taken, %llu scan-queue drops; root %llu scans, "
        "%llu frames synchronised, %llu fused; stopped in %.2f s\n",
        static_cast<unsigned long long>(flooded),
        static_cast<unsigned long long>(flood_sensor.dds->clouds),
        static_cast<unsigned long long>(stats.scan_queue_drops),
        static_cast<unsigned long long>(root.scans),
        static_cast<unsigned long long>(stats.frames_synchronised),
        static_cast<unsigned long long>(stats.frames_fused), stop_s);
    // The flood outran the pipeline (or the machine) and its surplus was dropped, counted.
    EXPECT_GT(flooded, 5u * kFrames);
    EXPECT_LT(flood_sensor.dds->clouds, flooded);
    // The root lost nothing to it: every one of its clouds became a scan and a frame.
    EXPECT_GE(root.scans, kFrames - 4u);  // its own reader keeps 8 on a loaded machine
    EXPECT_GE(stats.frames_synchronised + 2, root.scans);
    EXPECT_GT(stats.frames_fused, 0u);
    EXPECT_LT(stop_s, 5.0);
}

}  // namespace
}  // namespace lidarfuse::daemon
