#pragma once
// Helpers of the lidarfused tests (lidarfused_test, lidarfused_tf_test): the daemon as a
// child process with its log, the test's DDS readers of everything it publishes, a run fed
// by a replay or a live simulation, and tf2's view of what was published.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <thread>

#include "daemon/dds_messages.hpp"
#include "daemon/sensor_ingest.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/pose_csv.hpp"
#include "tests/daemon/dds_test_support.hpp"
#include "tests/daemon/tf2_model.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::lidarfused_test {

// Ports for this test: this process's block, reserved so parallel test runs never collide.
inline std::uint16_t base_port() { return test::port_block(); }

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
    // Frames whose poses message calls a sensor "predicted" (sync.when_behind: predict).
    std::set<std::int64_t> predicted_frames;
    std::size_t clouds = 0, poses = 0, tf_messages = 0, points = 0;
    std::size_t sampled_points = 0, sampled_with_intensity = 0;  // every 97th point
    std::set<int> cloud_sensor_ids;
    std::vector<io::PoseRecord> tf;  // rt/tf as poses.csv rows (frame = message number)
    // rt/tf_static: messages, and every transform as a row (sensor = child frame) with its parent.
    std::size_t tf_static_messages = 0;
    std::vector<io::PoseRecord> tf_static;
    std::vector<std::string> tf_static_parents;
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
                if (std::string(s.track_state) == "predicted")
                    seen->predicted_frames.insert(m.frame_index);
            }
            seen->frames.push_back(std::move(p));
        });
        tf_static.take([&](const tf2_msgs_msg_dds__TFMessage_& m) {
            ++seen->tf_static_messages;
            EXPECT_GT(m.transforms._length, 0u) << "an empty tf_static message";
            for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
                const auto& t = m.transforms._buffer[i];
                seen->note_stamp(daemon::from_ros_time(t.header.stamp));
                seen->tf_static.push_back({0, t.child_frame_id,
                                           daemon::from_ros_time(t.header.stamp),
                                           daemon::from_ros_transform(t.transform)});
                seen->tf_static_parents.push_back(t.header.frame_id);
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
inline std::size_t frames_with_tf(const DdsSeen& seen) {
    std::size_t n = 0;
    for (const auto& f : seen.frames) n += !f.stamped.empty();
    return n;
}

// tf2's view of a run: nothing it would warn about, nothing stamped 0, and every cloud's
// stamp resolves for every sensor with a scan and a pose in it. The one lookup tf2 cannot
// make is in a sensor's first frame on tf, when its scan is later than the frame's stamp
// (no earlier sample to interpolate from); returns how many of those there were.
inline std::size_t expect_every_cloud_resolves(const DdsSeen& seen) {
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

// The road or geo world frame is fixed only after the initial registration, which runs on
// a worker while the replay goes on: on a loaded machine or a sanitizer build it can take
// longer than a short capture lasts (measured: 3.2 s for 2 sensors, 6.8 s for 4, with the
// whole suite running on 2 cores), and then nothing is published. A test that needs
// published frames skips then, saying why, as it does for a registration too late to see
// a sensor's silence.
inline bool world_frame_never_fixed(const std::string& daemon_log) {
    return daemon_log.find(") fixed at frame") == std::string::npos;
}

inline pid_t start_daemon(const std::filesystem::path& config, const std::filesystem::path& log) {
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

// `lidarfuse sim` of the curve with two sensors, `seconds` long, into `out` (capture,
// metadata, ground truth). Call through ASSERT_NO_FATAL_FAILURE.
inline void simulate_two_sensors(const std::filesystem::path& out, double seconds) {
    std::string text;
    ASSERT_EQ(test::run_command(test::tool_path() + " sim --scenario curve --sensors 2 --seconds " +
                                    std::to_string(seconds) + " --out " + out.string(),
                                &text),
              0)
        << text;
}

// `lidarfuse replay OPTIONS CAPTURE` of simulate_two_sensors' capture into ports p0 and
// p0 + 2 (the simulator's sensors send to 7502 and 7504).
inline std::string replay_two_sensors(const std::string& options,
                                      const std::filesystem::path& capture, std::uint16_t p0) {
    return test::tool_path() + " replay " + options + " " + capture.string() +
           " --port-map 7502:" + std::to_string(p0) + " --port-map 7504:" + std::to_string(p0 + 2);
}

inline std::string read_text(const std::filesystem::path& file) {
    std::ifstream in(file);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// What a daemon run fed by a command saw: the command's status and output, the daemon's
// exit status.
struct FedRun {
    int feed_status = -1;
    std::string feed_output;
    int daemon_status = -1;
};

// lidarfused on `config` (its log to `log`), fed by the shell command `feed` (a replay or a
// live simulation) once it listens and its DDS writer is discovered, stopped with SIGTERM.
// `readers` take into `seen` while the feed runs (at most `feed_tries` tries), for 200
// tries after it (fusion catching up) and once more after the daemon exited. Call through
// ASSERT_NO_FATAL_FAILURE.
inline void run_fed_daemon(const std::filesystem::path& config, const std::filesystem::path& log,
                           const std::string& feed, int feed_tries, DaemonReaders* readers,
                           DdsSeen* seen, FedRun* run) {
    ChildGuard guard{start_daemon(config, log)};
    ASSERT_TRUE(test::eventually(
        [&] { return read_text(log).find("listening on UDP") != std::string::npos; }, 1000));
    ASSERT_TRUE(readers->points.wait_matched());
    std::atomic<int> feed_status{-1};
    std::thread feeder([&] { feed_status = test::run_command(feed, &run->feed_output); });
    test::eventually(
        [&] {
            readers->take(seen);
            return feed_status >= 0;
        },
        feed_tries);
    feeder.join();
    run->feed_status = feed_status.load();
    EXPECT_EQ(run->feed_status, 0) << run->feed_output;
    test::eventually(
        [&] {
            readers->take(seen);
            return false;
        },
        200);
    ASSERT_EQ(::kill(guard.pid, SIGTERM), 0);
    ASSERT_EQ(::waitpid(guard.pid, &run->daemon_status, 0), guard.pid);
    guard.pid = 0;
    EXPECT_TRUE(WIFEXITED(run->daemon_status) && WEXITSTATUS(run->daemon_status) == 0);
    test::eventually(
        [&] {
            readers->take(seen);
            return false;
        },
        30);
}

}  // namespace lidarfuse::lidarfused_test
