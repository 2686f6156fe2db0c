// The lidarfused binary: config validation, and a simulated station replayed through its
// sockets on loopback, subscribed to over DDS from this process, stopped with SIGTERM.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include "daemon/dds_messages.hpp"
#include "daemon/sensor_ingest.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/pose_csv.hpp"
#include "tests/daemon/dds_test_support.hpp"
#include "tests/daemon/tf2_model.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

using ::testing::HasSubstr;

TEST(Lidarfused, CheckAcceptsAValidConfigAndListsEveryProblemOfABadOne) {
    test::use_loopback_dds();
    test::TempDir dir("lfd");
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 2 --seconds 0.1 --out " +
                                    dir.path().string(),
                                &out),
              0)
        << out;
    out.clear();
    EXPECT_EQ(test::run_command(test::daemon_path() + " --config " +
                                    (dir.path() / "station.yaml").string() + " --check",
                                &out),
              0)
        << out;
    std::ofstream(dir.path() / "bad.yaml")
        << "sensors:\n  - {name: x, udp_port: 99999, metadata: nope.json}\n"
           "registration: {voxel_size_m: 0}\n";
    out.clear();
    EXPECT_EQ(test::run_command(
                  test::daemon_path() + " --config " + (dir.path() / "bad.yaml").string(), &out),
              1);
    EXPECT_THAT(out, HasSubstr("sensors[0].udp_port"));
    EXPECT_THAT(out, HasSubstr("sensors[0].metadata: file not found"));
    EXPECT_THAT(out, HasSubstr("registration.voxel_size_m"));
}

// Ports for this test: distinct per process so parallel test runs do not collide.
std::uint16_t base_port() { return static_cast<std::uint16_t>(42000 + (::getpid() % 4000) * 4); }

// Kills the daemon when a test ends early (a failed ASSERT), so it never outlives the test.
struct ChildGuard {
    pid_t pid = 0;
    ~ChildGuard() {
        if (pid <= 0) return;
        ::kill(pid, SIGKILL);
        ::waitpid(pid, nullptr, 0);
    }
};

// One rt/<ns>/poses message: the frame's stamp and the sensors with a scan and a pose in it.
struct PosesSeen {
    std::int64_t stamp_ns = 0;
    std::vector<std::string> stamped;  // included and pose_valid
};

// What the test's DDS readers saw of one run.
struct DdsSeen {
    std::set<std::int64_t> cloud_stamps, pose_frames;
    std::size_t clouds = 0, poses = 0, tf_messages = 0, points = 0;
    std::size_t sampled_points = 0, sampled_with_intensity = 0;  // every 97th point
    std::set<int> cloud_sensor_ids;
    std::vector<io::PoseRecord> tf;    // rt/tf as poses.csv rows (frame = message number)
    bool all_ok_seen = false;          // a diagnostics message with every sensor's state OK
    std::set<std::string> registered;  // sensors some diagnostics message called registered
    std::map<std::string, std::string> last_pipeline;  // the last pipeline status values
    test::Tf2Model tf2;                                // rt/tf and rt/tf_static, in arrival order
    std::vector<PosesSeen> frames;                     // rt/<ns>/poses in arrival order
    std::size_t zero_stamps = 0;                       // messages or transforms stamped 0
    std::int64_t min_stamp = 0, max_stamp = 0;         // over every stamp seen
    void note_stamp(std::int64_t t) {
        zero_stamps += t == 0;
        if (t == 0) return;
        min_stamp = min_stamp == 0 ? t : std::min(min_stamp, t);
        max_stamp = std::max(max_stamp, t);
    }
};

struct DaemonReaders {
    explicit DaemonReaders(int domain)
        : participant(
              dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr)),
          points(participant, &sensor_msgs_msg_dds__PointCloud2__desc, "rt/lidarfuse/points",
                 test::reader_qos(50)),
          poses(participant, &lidarfuse_msgs_msg_dds__FramePoses__desc, "rt/lidarfuse/poses",
                test::reader_qos(50)),
          tf(participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", test::reader_qos(50)),
          tf_static(participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf_static",
                    test::reader_qos(1, true)),
          diagnostics(participant, &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
                      "rt/diagnostics", test::reader_qos(50)) {}
    ~DaemonReaders() { dds_delete(participant); }

    void take(DdsSeen* seen) {
        points.take([&](const sensor_msgs_msg_dds__PointCloud2_& m) {
            ++seen->clouds;
            seen->cloud_stamps.insert(daemon::from_ros_time(m.header.stamp));
            seen->note_stamp(daemon::from_ros_time(m.header.stamp));
            seen->points += m.width;
            for (std::uint32_t i = 0; i < m.width; i += 97) {
                seen->cloud_sensor_ids.insert(
                    m.data._buffer[i * m.point_step + daemon::kOffsetSensorId]);
                float intensity = 0.0f;
                std::memcpy(&intensity,
                            m.data._buffer + i * m.point_step + daemon::kOffsetIntensity,
                            sizeof intensity);
                ++seen->sampled_points;
                seen->sampled_with_intensity += intensity > 0.0f;
            }
        });
        poses.take([&](const lidarfuse_msgs_msg_dds__FramePoses_& m) {
            ++seen->poses;
            seen->pose_frames.insert(m.frame_index);
            PosesSeen p{daemon::from_ros_time(m.header.stamp), {}};
            seen->note_stamp(p.stamp_ns);
            for (std::uint32_t i = 0; i < m.sensors._length; ++i) {
                const auto& s = m.sensors._buffer[i];
                seen->note_stamp(daemon::from_ros_time(s.stamp));
                if (s.included && s.pose_valid) p.stamped.push_back(s.name);
            }
            seen->frames.push_back(std::move(p));
        });
        tf_static.take([&](const tf2_msgs_msg_dds__TFMessage_& m) {
            for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
                const auto& t = m.transforms._buffer[i];
                seen->tf2.add(t.header.frame_id, t.child_frame_id,
                              daemon::from_ros_time(t.header.stamp), true);
            }
        });
        tf.take([&](const tf2_msgs_msg_dds__TFMessage_& m) {
            const auto number = static_cast<std::int64_t>(seen->tf_messages++);
            EXPECT_GT(m.transforms._length, 0u) << "an empty tf message";
            for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
                const auto& t = m.transforms._buffer[i];
                EXPECT_STREQ(t.header.frame_id, "station_world");
                seen->note_stamp(daemon::from_ros_time(t.header.stamp));
                seen->tf2.add(t.header.frame_id, t.child_frame_id,
                              daemon::from_ros_time(t.header.stamp), false);
                seen->tf.push_back({number, t.child_frame_id, daemon::from_ros_time(t.header.stamp),
                                    daemon::from_ros_transform(t.transform)});
            }
        });
        diagnostics.take([&](const diagnostic_msgs_msg_dds__DiagnosticArray_& m) {
            seen->note_stamp(daemon::from_ros_time(m.header.stamp));
            bool all_ok = m.status._length == 3;  // two sensors and the pipeline
            for (std::uint32_t i = 0; i < m.status._length; ++i) {
                const auto& st = m.status._buffer[i];
                std::map<std::string, std::string> values;
                for (std::uint32_t k = 0; k < st.values._length; ++k) {
                    values[st.values._buffer[k].key] = st.values._buffer[k].value;
                }
                if (i + 1 == m.status._length) {
                    seen->last_pipeline = values;
                } else {
                    all_ok = all_ok && values["state"] == "OK" &&
                             std::string(st.message).rfind("OK", 0) == 0;
                    if (values["pose_valid"] == "true") seen->registered.insert(st.hardware_id);
                }
            }
            seen->all_ok_seen = seen->all_ok_seen || all_ok;
        });
    }

    dds_entity_t participant;
    test::DdsReader<sensor_msgs_msg_dds__PointCloud2_> points;
    test::DdsReader<lidarfuse_msgs_msg_dds__FramePoses_> poses;
    test::DdsReader<tf2_msgs_msg_dds__TFMessage_> tf;
    test::DdsReader<tf2_msgs_msg_dds__TFMessage_> tf_static;
    test::DdsReader<diagnostic_msgs_msg_dds__DiagnosticArray_> diagnostics;
};

// Frames with a sensor that has a scan and a pose: exactly those get an rt/tf message.
std::size_t frames_with_tf(const DdsSeen& seen) {
    std::size_t n = 0;
    for (const auto& f : seen.frames) n += !f.stamped.empty();
    return n;
}

// tf2's view of a run: nothing it would warn about, nothing stamped 0, and every cloud's
// stamp resolves for every sensor with a scan and a pose in it. The one lookup tf2 cannot
// make is in a sensor's first frame on tf, when its scan is later than the frame's stamp
// (no earlier sample to interpolate from); returns how many of those there were.
std::size_t expect_every_cloud_resolves(const DdsSeen& seen) {
    EXPECT_TRUE(seen.tf2.warnings.empty()) << seen.tf2.warnings.front();
    EXPECT_EQ(seen.zero_stamps, 0u);
    std::size_t first_frame_misses = 0;
    std::set<std::string> on_tf_before;
    for (const auto& frame : seen.frames) {
        EXPECT_TRUE(seen.cloud_stamps.count(frame.stamp_ns)) << "a poses stamp without a cloud";
        for (const auto& sensor : frame.stamped) {
            std::string why;
            const bool first = on_tf_before.insert(sensor).second;
            if (seen.tf2.resolves(sensor, frame.stamp_ns, &why)) continue;
            if (first && why == "extrapolation into the past" &&
                seen.tf2.first_stamp(sensor) > frame.stamp_ns) {
                ++first_frame_misses;
                continue;
            }
            ADD_FAILURE() << sensor << " at the cloud stamp " << frame.stamp_ns << ": " << why;
        }
    }
    return first_frame_misses;
}

TEST(Lidarfused, FusesAReplayedStationOntoDdsAndStopsCleanlyOnSigterm) {
    test::TempDir dir("lfd-run");
    const auto d = dir.path();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 2 --seconds 1 --out " +
                                    (d / "sim").string(),
                                &out),
              0)
        << out;
    const std::uint16_t p0 = base_port(), p1 = static_cast<std::uint16_t>(p0 + 2);
    test::use_loopback_dds();  // this process and the daemon
    const int domain = test::unique_domain_id();
    std::ofstream(d / "sim" / "daemon.yaml")
        << "station: test\nroot: lidar0\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p1 << ", metadata: lidar1.json}\n"
        << "network: {bind_address: 127.0.0.1}\noutput:\n  directory: " << (d / "out").string()
        << "\n"
        << "  dds: {domain_id: " << domain
        << ", frame_id: station_world, diagnostics_period_ms: 200}\n";
    // Subscribed before the daemon starts, so every frame it publishes can be counted.
    DaemonReaders readers(domain);
    DdsSeen seen;

    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        const std::string config = (d / "sim" / "daemon.yaml").string();
        const std::string log = (d / "daemon.log").string();
        std::freopen(log.c_str(), "w", stderr);
        std::freopen(log.c_str(), "a", stdout);
        ::execl(test::daemon_path().c_str(), "lidarfused", "--config", config.c_str(), nullptr);
        ::_exit(127);
    }
    ChildGuard guard{pid};
    // Wait until it listens (its log says so), then replay through its sockets.
    bool listening = false;
    for (int i = 0; i < 200 && !listening; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        std::ifstream log(d / "daemon.log");
        std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
        listening = text.find("listening on UDP") != std::string::npos;
    }
    ASSERT_TRUE(listening);
    ASSERT_TRUE(readers.points.wait_matched()) << "the daemon's writer was not discovered";
    out.clear();
    std::atomic<int> replay_status{-1};
    std::thread replay([&] {
        replay_status = test::run_command(
            test::tool_path() + " replay " + (d / "sim" / "capture.pcap").string() +
                " --port-map 7502:" + std::to_string(p0) + " --port-map 7504:" + std::to_string(p1),
            &out);
    });
    // Take while the replay runs and for two seconds after (fusion catching up).
    test::eventually(
        [&] {
            readers.take(&seen);
            return replay_status >= 0;
        },
        6000);
    replay.join();
    EXPECT_EQ(replay_status.load(), 0) << out;
    test::eventually(
        [&] {
            readers.take(&seen);
            return false;
        },
        200);
    ASSERT_EQ(::kill(pid, SIGTERM), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    guard.pid = 0;
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
    // The final diagnostics went out during shutdown; then the daemon's writers are gone.
    EXPECT_TRUE(test::eventually([&] {
        readers.take(&seen);
        dds_subscription_matched_status_t st{};
        dds_get_subscription_matched_status(readers.diagnostics.reader(), &st);
        return st.current_count == 0;
    }));

    std::ifstream log(d / "daemon.log");
    const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    // How many frames get fused depends on the machine (a slow fusion drops the oldest
    // frames, counted); what must hold is that every fused frame has its root pose written.
    const auto fused = test::line_after(text, "stopped: fused ");
    ASSERT_TRUE(fused.has_value()) << text;
    const auto poses = io::read_pose_csv(d / "out" / "poses.csv");
    std::size_t root_rows = 0;
    for (const auto& p : poses) root_rows += p.sensor == "lidar0";
    EXPECT_GE(root_rows, 1u) << text;
    const std::size_t frames_fused = std::stoul(*fused);
    EXPECT_EQ(root_rows, frames_fused) << text;

    // DDS: one cloud, one poses message and one tf message per fused frame, none lost.
    EXPECT_EQ(seen.clouds, frames_fused) << text;
    EXPECT_EQ(seen.cloud_stamps.size(), frames_fused);
    EXPECT_EQ(seen.poses, frames_fused);
    EXPECT_EQ(seen.pose_frames.size(), frames_fused);
    EXPECT_EQ(seen.tf_messages, frames_with_tf(seen));
    EXPECT_GT(seen.points, 1000u * frames_fused);
    EXPECT_TRUE(seen.cloud_sensor_ids.count(0));  // the root's points, at least, are in the clouds
    // Intensity is the sensors' signal: most returns of the simulated street have some.
    EXPECT_GT(seen.sampled_with_intensity, seen.sampled_points / 2)
        << seen.sampled_with_intensity << " of " << seen.sampled_points << " sampled points";
    EXPECT_TRUE(seen.all_ok_seen) << "no diagnostics with every sensor OK";
    EXPECT_EQ(seen.last_pipeline["frames_fused"], std::to_string(frames_fused));
    EXPECT_EQ(seen.last_pipeline["dds_write_failures"], "0");
    EXPECT_EQ(seen.last_pipeline["kernel_drops"], "0");
    std::string registered_names;
    for (const auto& name : seen.registered) registered_names += " " + name;
    std::printf("lidarfused over DDS: %zu frames fused, %zu clouds, %zu points, registered:%s\n",
                frames_fused, seen.clouds, seen.points, registered_names.c_str());
    // Every sensor the daemon registered, the root included, is on rt/tf and in the clouds;
    // none is on rt/tf_static (they move), and tf2 resolves every cloud's stamp.
    std::set<std::string> on_tf;
    for (const auto& r : seen.tf) on_tf.insert(r.sensor);
    EXPECT_TRUE(seen.registered.count("lidar0"));
    EXPECT_EQ(on_tf, seen.registered);
    EXPECT_LE(expect_every_cloud_resolves(seen), 1u);  // at most lidar1's first frame on tf
    if (seen.registered.count("lidar1")) {
        EXPECT_TRUE(seen.cloud_sensor_ids.count(1));
    }

    // rt/tf against the simulator's ground truth, with the same evaluator as poses.csv.
    io::write_pose_csv(d / "tf.csv", seen.tf);
    std::string tf_eval;
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " +
                                    (d / "sim" / "ground_truth.csv").string() + " --poses " +
                                    (d / "tf.csv").string() + " --root lidar0",
                                &tf_eval),
              0)
        << tf_eval;
    EXPECT_THAT(tf_eval, HasSubstr("eval_mean_strict_rmse_trans 0.0")) << tf_eval;  // below 10 cm
    std::printf("rt/tf against ground truth: strict RMSE %s\n",
                test::line_after(tf_eval, "eval_mean_strict_rmse_trans ").value_or("?").c_str());
    std::string root;
    const auto extrinsics = io::read_extrinsics_yaml(d / "out" / "extrinsics.yaml", &root);
    EXPECT_EQ(root, "lidar0");
    ASSERT_EQ(extrinsics.size(), 2u);
    EXPECT_TRUE(extrinsics[0].registered);
    for (const auto& e : extrinsics)
        EXPECT_EQ(e.registered, seen.registered.count(e.name) > 0) << e.name;
    EXPECT_FALSE(std::filesystem::exists(d / "out" / "extrinsics.yaml.tmp"));

    out.clear();
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " +
                                    (d / "sim" / "ground_truth.csv").string() + " --poses " +
                                    (d / "out" / "poses.csv").string(),
                                &out),
              0)
        << out;
    EXPECT_THAT(out, HasSubstr("eval_mean_strict_rmse_trans 0.0"));  // centimetres, not metres
}

pid_t start_daemon(const std::filesystem::path& config, const std::filesystem::path& log) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        std::freopen(log.string().c_str(), "w", stderr);
        std::freopen(log.string().c_str(), "a", stdout);
        ::execl(test::daemon_path().c_str(), "lidarfused", "--config", config.string().c_str(),
                nullptr);
        ::_exit(127);
    }
    return pid;
}

std::string read_text(const std::filesystem::path& file) {
    std::ifstream in(file);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// `lidarfuse sim --live` sends a station's packets in real time while it simulates them
// (no capture file): the daemon fuses them and publishes every fused frame on DDS.
TEST(Lidarfused, FusesALiveSimulatedStationOntoDds) {
    test::use_loopback_dds();
    test::TempDir dir("lfd-live");
    const auto d = dir.path();
    std::string out;
    // The metadata of the same virtual sensors, before the live run starts.
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 2 --seconds 0.05 --out " +
                                    (d / "meta").string(),
                                &out),
              0)
        << out;
    const auto p0 = static_cast<std::uint16_t>(30000 + (::getpid() % 4000) * 4);
    const int domain = test::unique_domain_id();
    std::ofstream(d / "meta" / "daemon.yaml")
        << "station: live\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p0 + 2 << ", metadata: lidar1.json}\n"
        << "network: {bind_address: 127.0.0.1}\noutput:\n  directory: " << (d / "out").string()
        << "\n"
        << "  dds: {domain_id: " << domain << ", frame_id: station_world}\n";
    DaemonReaders readers(domain);
    DdsSeen seen;
    ChildGuard guard{start_daemon(d / "meta" / "daemon.yaml", d / "daemon.log")};
    ASSERT_TRUE(test::eventually(
        [&] { return read_text(d / "daemon.log").find("listening on UDP") != std::string::npos; },
        1000));
    ASSERT_TRUE(readers.points.wait_matched());
    std::atomic<int> sim_status{-1};
    std::string sim_out;
    std::thread live([&] {
        sim_status = test::run_command(
            test::tool_path() +
                " sim --scenario curve --sensors 2 --seconds 1 --live --to 127.0.0.1:" +
                std::to_string(p0) + " --out " + (d / "live").string(),
            &sim_out);
    });
    test::eventually(
        [&] {
            readers.take(&seen);
            return sim_status >= 0;
        },
        12000);
    live.join();
    EXPECT_EQ(sim_status.load(), 0) << sim_out;
    test::eventually(
        [&] {
            readers.take(&seen);
            return false;
        },
        200);
    ASSERT_EQ(::kill(guard.pid, SIGTERM), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(guard.pid, &status, 0), guard.pid);
    guard.pid = 0;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    test::eventually(
        [&] {
            readers.take(&seen);
            return false;
        },
        30);
    const std::string text = read_text(d / "daemon.log");
    const auto fused = test::line_after(text, "stopped: fused ");
    ASSERT_TRUE(fused.has_value()) << text;
    const std::size_t frames_fused = std::stoul(*fused);
    EXPECT_GE(frames_fused, 1u) << text;
    EXPECT_EQ(seen.clouds, frames_fused) << text;
    EXPECT_EQ(seen.poses, frames_fused);
    EXPECT_EQ(seen.tf_messages, frames_with_tf(seen));
    EXPECT_TRUE(seen.all_ok_seen);
    EXPECT_EQ(seen.last_pipeline["dds_write_failures"], "0");
    io::write_pose_csv(d / "tf.csv", seen.tf);
    std::string tf_eval;
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " +
                                    (d / "live" / "ground_truth.csv").string() + " --poses " +
                                    (d / "tf.csv").string() + " --root lidar0",
                                &tf_eval),
              0)
        << tf_eval;
    EXPECT_THAT(tf_eval, HasSubstr("eval_mean_strict_rmse_trans 0.0")) << tf_eval;
    std::printf("live: %zu frames fused, registered %zu sensors, rt/tf strict RMSE %s\n",
                frames_fused, seen.registered.size(),
                test::line_after(tf_eval, "eval_mean_strict_rmse_trans ").value_or("?").c_str());
}

// A sensor silenced for 1 s of a replay, stamps on the host's clock: tf2 resolves every
// cloud's stamp for every sensor in it (the silenced one is left out of the frames it
// misses, never sent with stamp 0), and every stamp is CLOCK_REALTIME of this run.
TEST(Lidarfused, TfResolvesEveryCloudWithASensorSilencedAndHostStamps) {
    test::use_loopback_dds();
    test::TempDir dir("lfd-tf2");
    const auto d = dir.path();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 2 --seconds 5 "
                                    "--fault silence:lidar1:3:1 --out " +
                                    (d / "sim").string(),
                                &out),
              0)
        << out;
    // A port range of its own (the other tests use 30000+ and 42000+).
    const auto p0 = static_cast<std::uint16_t>(10000 + (::getpid() % 4000) * 4);
    const int domain = test::unique_domain_id();
    std::ofstream(d / "sim" / "daemon.yaml")
        << "station: tf2\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p0 + 2 << ", metadata: lidar1.json}\n"
        << "network: {bind_address: 127.0.0.1}\noutput:\n  directory: " << (d / "out").string()
        << "\n  stamp: host\n"
        << "  dds: {domain_id: " << domain
        << ", frame_id: station_world, diagnostics_period_ms: 200}\n";
    DaemonReaders readers(domain);
    DdsSeen seen;
    const std::int64_t started_ns = daemon::realtime_ns();
    ChildGuard guard{start_daemon(d / "sim" / "daemon.yaml", d / "daemon.log")};
    ASSERT_TRUE(test::eventually(
        [&] { return read_text(d / "daemon.log").find("listening on UDP") != std::string::npos; },
        1000));
    ASSERT_TRUE(readers.points.wait_matched());
    std::atomic<int> replay_status{-1};
    std::thread replay([&] {
        replay_status = test::run_command(test::tool_path() + " replay " +
                                              (d / "sim" / "capture.pcap").string() +
                                              " --port-map 7502:" + std::to_string(p0) +
                                              " --port-map 7504:" + std::to_string(p0 + 2),
                                          &out);
    });
    test::eventually(
        [&] {
            readers.take(&seen);
            return replay_status >= 0;
        },
        12000);
    replay.join();
    EXPECT_EQ(replay_status.load(), 0) << out;
    test::eventually(
        [&] {
            readers.take(&seen);
            return false;
        },
        200);
    ASSERT_EQ(::kill(guard.pid, SIGTERM), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(guard.pid, &status, 0), guard.pid);
    guard.pid = 0;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    test::eventually(
        [&] {
            readers.take(&seen);
            return false;
        },
        30);
    const std::int64_t stopped_ns = daemon::realtime_ns();
    const std::string text = read_text(d / "daemon.log");
    ASSERT_FALSE(seen.frames.empty()) << text;
    const std::size_t misses = expect_every_cloud_resolves(seen);
    EXPECT_LE(misses, 1u);  // at most lidar1's first frame on tf (the root's is its own stamp)
    EXPECT_EQ(seen.tf_messages, frames_with_tf(seen));
    // The host's clock: every stamp within this run (the simulated sensors' clock is not).
    EXPECT_GE(seen.min_stamp, started_ns);
    EXPECT_LE(seen.max_stamp, stopped_ns);
    // The silence is covered: frames with lidar1, then without it, then with it again.
    std::vector<bool> has1;
    for (const auto& f : seen.frames) {
        has1.push_back(std::find(f.stamped.begin(), f.stamped.end(), "lidar1") != f.stamped.end());
    }
    const auto first_with = std::find(has1.begin(), has1.end(), true);
    const auto gap = std::find(first_with, has1.end(), false);
    const auto back = std::find(gap, has1.end(), true);
    std::printf("tf2 model: %zu frames, lidar1 in %td, tf2 misses in a first frame %zu\n",
                seen.frames.size(), std::count(has1.begin(), has1.end(), true), misses);
    if (first_with == has1.end()) GTEST_SKIP() << "lidar1 was not registered before the silence";
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    // Under the sanitizers the daemon fuses a frame in hundreds of ms and registers lidar1
    // only late in the replay (measured under ASan: 24 frames, lidar1 in the last one), so
    // the silence may lie before its first frame; the tf checks above still ran.
    if (gap == has1.end()) GTEST_SKIP() << "lidar1 registered only after its silence (sanitizer build)";
#endif
    EXPECT_NE(gap, has1.end()) << "no frame without lidar1 during its silence";
    EXPECT_NE(back, has1.end()) << "lidar1 did not come back after its silence";
}

// The daemon speaks systemd's notify protocol: READY=1 once bound, WATCHDOG=1 while the
// fusion heartbeat is fresh, STATUS= lines, STOPPING=1 on SIGTERM.
TEST(Lidarfused, SpeaksTheSystemdNotifyProtocol) {
    test::use_loopback_dds();
    test::TempDir dir("lfd-notify");
    const auto d = dir.path();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 1 --seconds 0.1 --out " +
                                    (d / "sim").string(),
                                &out),
              0)
        << out;
    std::ofstream(d / "sim" / "daemon.yaml")
        << "sensors:\n  - {name: lidar0, udp_port: " << base_port() + 1
        << ", metadata: lidar0.json}\n"
        << "network: {bind_address: 127.0.0.1}\noutput: {directory: " << (d / "out").string()
        << ", dds: {domain_id: " << test::unique_domain_id() << "}}\n";
    const std::string socket_path = (d / "notify.sock").string();
    const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    ASSERT_GE(fd, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, socket_path.c_str(), sizeof(addr.sun_path) - 1);
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    timeval tv{20, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));

    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        ::setenv("NOTIFY_SOCKET", socket_path.c_str(), 1);
        ::setenv("WATCHDOG_USEC", "400000", 1);
        ::unsetenv("WATCHDOG_PID");
        const std::string config = (d / "sim" / "daemon.yaml").string();
        std::freopen((d / "daemon.log").string().c_str(), "w", stderr);
        ::execl(test::daemon_path().c_str(), "lidarfused", "--config", config.c_str(), nullptr);
        ::_exit(127);
    }
    const auto receive = [fd] {
        char buffer[1024];
        const ssize_t n = ::recv(fd, buffer, sizeof(buffer), 0);
        return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
    };
    EXPECT_THAT(receive(), HasSubstr("READY=1\nSTATUS=listening on UDP"));
    bool watchdog = false, status = false;
    for (int i = 0; i < 40 && !(watchdog && status); ++i) {
        const auto message = receive();
        watchdog = watchdog || message == "WATCHDOG=1";
        status = status || message.rfind("STATUS=fused ", 0) == 0;
    }
    EXPECT_TRUE(watchdog);
    EXPECT_TRUE(status);
    ASSERT_EQ(::kill(pid, SIGTERM), 0);
    bool stopping = false;
    for (int i = 0; i < 20 && !stopping; ++i) stopping = receive() == "STOPPING=1";
    EXPECT_TRUE(stopping);
    int exit_status = 0;
    ASSERT_EQ(::waitpid(pid, &exit_status, 0), pid);
    EXPECT_TRUE(WIFEXITED(exit_status) && WEXITSTATUS(exit_status) == 0);
    ::close(fd);
}

}  // namespace
}  // namespace lidarfuse
