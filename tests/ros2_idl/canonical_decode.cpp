// What a ROS 2 reader decodes of lidarfused's output: a replayed station subscribed to with
// the types of tests/ros2_idl/ (the canonical .msg files converted by rosidl's rules,
// written independently of daemon/idl/), every field compared with what the daemon wrote
// to its files: rt/lidarfuse/poses and rt/tf with poses.csv, every cloud with the PLY of
// the same frame. Built without the daemon's libraries (its IDL has the same C names).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include "diagnostic_msgs/msg/DiagnosticArray.h"
#include "drivers/io/fused_cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"
#include "lidarfuse_msgs/msg/FramePoses.h"
#include "sensor_msgs/msg/PointCloud2.h"
#include "tests/daemon/dds_test_support.hpp"
#include "tests/support/test_data.hpp"
#include "tf2_msgs/msg/TFMessage.h"

namespace lidarfuse {
namespace {

std::int64_t ns(const builtin_interfaces_msg_dds__Time_& t) {
    return static_cast<std::int64_t>(t.sec) * 1'000'000'000 + t.nanosec;
}

Eigen::Isometry3d pose(const geometry_msgs_msg_dds__Transform_& t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(t.translation.x, t.translation.y, t.translation.z);
    T.linear() = Eigen::Quaterniond(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z)
                     .toRotationMatrix();
    return T;
}

// poses.csv holds 1e-6 m and 1e-9 of a quaternion: equal to that.
void expect_same_pose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b,
                      const std::string& what) {
    EXPECT_LE((a.translation() - b.translation()).norm(), 1e-6 * std::sqrt(3.0)) << what;
    EXPECT_LE(Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle(), 1e-8) << what;
}

struct Seen {
    std::vector<std::pair<std::int64_t, std::vector<float>>> clouds;  // stamp, raw x y z i
    std::vector<std::vector<std::uint8_t>> cloud_ids;                 // sensor_id, dynamic
    std::map<std::int64_t, std::int64_t> frame_of_stamp;              // poses: stamp -> frame
    std::vector<io::PoseRecord> pose_rows, tf_rows;  // included and registered sensors
    std::set<std::string> diagnostic_names;
};

struct Readers {
    explicit Readers(int domain)
        : participant(
              dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr)),
          points(participant, &sensor_msgs_msg_dds__PointCloud2__desc, "rt/lidarfuse/points",
                 test::reader_qos(100)),
          poses(participant, &lidarfuse_msgs_msg_dds__FramePoses__desc, "rt/lidarfuse/poses",
                test::reader_qos(100)),
          tf(participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", test::reader_qos(100)),
          diagnostics(participant, &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
                      "rt/diagnostics", test::reader_qos(100)) {}
    ~Readers() { dds_delete(participant); }

    void take(Seen* seen) {
        points.take([&](const sensor_msgs_msg_dds__PointCloud2_& m) {
            EXPECT_EQ(m.point_step, 20u);
            ASSERT_EQ(m.fields._length, 6u);
            std::vector<float> xyzi(4 * std::size_t{m.width});
            std::vector<std::uint8_t> ids(2 * std::size_t{m.width});
            for (std::uint32_t i = 0; i < m.width; ++i) {
                const std::uint8_t* p = m.data._buffer + std::size_t{i} * m.point_step;
                std::memcpy(&xyzi[4 * std::size_t{i}], p, 4 * sizeof(float));
                ids[2 * std::size_t{i}] = p[16];
                ids[2 * std::size_t{i} + 1] = p[17];
            }
            seen->clouds.emplace_back(ns(m.header.stamp), std::move(xyzi));
            seen->cloud_ids.push_back(std::move(ids));
        });
        poses.take([&](const lidarfuse_msgs_msg_dds__FramePoses_& m) {
            seen->frame_of_stamp[ns(m.header.stamp)] = m.frame_index;
            for (std::uint32_t i = 0; i < m.sensors._length; ++i) {
                const auto& s = m.sensors._buffer[i];
                if (!s.included || !s.pose_valid) continue;
                seen->pose_rows.push_back({m.frame_index, s.name, ns(s.stamp), pose(s.transform)});
            }
        });
        tf.take([&](const tf2_msgs_msg_dds__TFMessage_& m) {
            for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
                const auto& t = m.transforms._buffer[i];
                EXPECT_STREQ(t.header.frame_id, "station_world");
                seen->tf_rows.push_back(
                    {0, t.child_frame_id, ns(t.header.stamp), pose(t.transform)});
            }
        });
        diagnostics.take([&](const diagnostic_msgs_msg_dds__DiagnosticArray_& m) {
            for (std::uint32_t i = 0; i < m.status._length; ++i)
                seen->diagnostic_names.insert(m.status._buffer[i].name);
        });
    }

    dds_entity_t participant;
    test::DdsReader<sensor_msgs_msg_dds__PointCloud2_> points;
    test::DdsReader<lidarfuse_msgs_msg_dds__FramePoses_> poses;
    test::DdsReader<tf2_msgs_msg_dds__TFMessage_> tf;
    test::DdsReader<diagnostic_msgs_msg_dds__DiagnosticArray_> diagnostics;
};

std::string read_text(const std::filesystem::path& file) {
    std::ifstream in(file);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Runs lidarfused on a replayed 2-sensor station, every fused cloud also written as PLY.
void run_station(const std::filesystem::path& d, Readers* readers, Seen* seen) {
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 2 --seconds 1 --out " +
                                    (d / "sim").string(),
                                &out),
              0)
        << out;
    const auto p0 = test::port_block();
    std::ofstream(d / "sim" / "daemon.yaml")
        << "station: canon\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p0 + 2
        << ", metadata: lidar1.json}\n"
        // The root frame: every fused frame is published from the first on (the 1 s capture
        // could end before the initial registration fixes a road frame).
        << "network: {bind_address: 127.0.0.1}\nworld: {frame: sensor}\noutput:\n  directory: "
        << (d / "out").string() << "\n  record_clouds_every: 1\n"
        << "  dds: {domain_id: " << test::unique_domain_id()
        << ", frame_id: station_world, diagnostics_period_ms: 200}\n";
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        std::freopen((d / "daemon.log").string().c_str(), "w", stderr);
        std::freopen((d / "daemon.log").string().c_str(), "a", stdout);
        ::execl(test::daemon_path().c_str(), "lidarfused", "--config",
                (d / "sim" / "daemon.yaml").string().c_str(), nullptr);
        ::_exit(127);
    }
    const bool listening = test::eventually(
        [&] { return read_text(d / "daemon.log").find("listening on UDP") != std::string::npos; },
        1000);
    const bool matched = listening && readers->points.wait_matched();
    std::atomic<int> replay_status{-1};
    std::thread replay([&] {
        if (!matched) return;
        replay_status = test::run_command(test::tool_path() + " replay " +
                                              (d / "sim" / "capture.pcap").string() +
                                              " --port-map 7502:" + std::to_string(p0) +
                                              " --port-map 7504:" + std::to_string(p0 + 2),
                                          &out);
    });
    test::eventually(
        [&] {
            readers->take(seen);
            return !matched || replay_status >= 0;
        },
        6000);
    replay.join();
    test::eventually(
        [&] {
            readers->take(seen);
            return false;
        },
        200);
    ::kill(pid, SIGTERM);
    int status = 0;
    ::waitpid(pid, &status, 0);
    readers->take(seen);
    ASSERT_TRUE(matched) << read_text(d / "daemon.log");
    EXPECT_EQ(replay_status.load(), 0) << out;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

TEST(CanonicalRos2Types, DecodeEverySampleEqualToTheDaemonsFiles) {
    test::use_loopback_dds();
    test::TempDir dir("lfd-canon");
    Readers readers(test::unique_domain_id());
    Seen seen;
    run_station(dir.path(), &readers, &seen);
    if (HasFatalFailure()) return;

    // poses.csv: exactly the registered sensors with a scan, on the poses topic and on tf.
    const auto csv = io::read_pose_csv(dir.path() / "out" / "poses.csv");
    ASSERT_FALSE(csv.empty());
    std::map<std::pair<std::string, std::int64_t>, const io::PoseRecord*> by_scan;
    for (const auto& r : csv) by_scan[{r.sensor, r.t_ns}] = &r;
    ASSERT_EQ(seen.pose_rows.size(), csv.size());
    ASSERT_EQ(seen.tf_rows.size(), csv.size());
    for (const auto* rows : {&seen.pose_rows, &seen.tf_rows}) {
        for (const auto& r : *rows) {
            const auto it = by_scan.find({r.sensor, r.t_ns});
            ASSERT_NE(it, by_scan.end()) << r.sensor << " at " << r.t_ns << " is not in poses.csv";
            if (rows == &seen.pose_rows) {
                EXPECT_EQ(r.frame, it->second->frame);
            }
            expect_same_pose(r.pose, it->second->pose, r.sensor);
        }
    }

    // Every cloud: the PLY the daemon wrote for the same frame, point by point.
    ASSERT_FALSE(seen.clouds.empty());
    for (std::size_t c = 0; c < seen.clouds.size(); ++c) {
        const auto frame = seen.frame_of_stamp.find(seen.clouds[c].first);
        ASSERT_NE(frame, seen.frame_of_stamp.end()) << "a cloud without its poses message";
        const core::FusedCloud ply = io::read_fused_cloud_ply(
            dir.path() / "out" / ("fused_" + std::to_string(frame->second) + ".ply"));
        const auto& xyzi = seen.clouds[c].second;
        const auto& ids = seen.cloud_ids[c];
        ASSERT_EQ(xyzi.size(), 4 * ply.points.size()) << "frame " << frame->second;
        for (std::size_t i = 0; i < ply.points.size(); ++i) {
            ASSERT_EQ(xyzi[4 * i], ply.points[i].x());
            ASSERT_EQ(xyzi[4 * i + 1], ply.points[i].y());
            ASSERT_EQ(xyzi[4 * i + 2], ply.points[i].z());
            ASSERT_EQ(xyzi[4 * i + 3], ply.intensity[i]);
            ASSERT_EQ(ids[2 * i], ply.sensor[i]);
            ASSERT_EQ(ids[2 * i + 1], ply.dynamic[i]);
        }
    }
    EXPECT_TRUE(seen.diagnostic_names.count("lidarfuse/canon/lidar0"));
    EXPECT_TRUE(seen.diagnostic_names.count("lidarfuse/canon/pipeline"));
    std::printf("canonical types: %zu clouds, %zu pose rows, %zu tf rows equal to the files\n",
                seen.clouds.size(), seen.pose_rows.size(), seen.tf_rows.size());
}

}  // namespace
}  // namespace lidarfuse
