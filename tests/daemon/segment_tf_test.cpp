// A road segment's tf chain (issue 20; output.dds.frame_prefix, sensors[].source.dds.frame_id):
// a station pipeline and a segment pipeline on one DDS domain, and what a tf listener hears
// of both on rt/tf.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <thread>

#include "core/common/se3.hpp"
#include "daemon/dds_messages.hpp"
#include "daemon/pipeline.hpp"
#include "tests/daemon/dds_sources.hpp"
#include "tests/daemon/dds_test_support.hpp"

namespace lidarfuse::daemon {
namespace {

using dds_sources::DriverTopics;
using dds_sources::settled_stats;

// Every transform heard on rt/tf, by child frame: its parents (tf2 allows one) and the
// newest transform.
struct TfTree {
    std::map<std::string, std::set<std::string>> parents;
    std::map<std::string, Eigen::Isometry3d> newest;

    void add(const tf2_msgs_msg_dds__TFMessage_& m) {
        for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
            const auto& t = m.transforms._buffer[i];
            parents[t.child_frame_id].insert(t.header.frame_id);
            newest[t.child_frame_id] = from_ros_transform(t.transform);
        }
    }
    std::string parent(const std::string& child) const {
        const auto it = parents.find(child);
        return it == parents.end() || it->second.size() != 1 ? "" : *it->second.begin();
    }
};

// A road segment's frames (issue 20): a station publishes its tf tree under its frame
// prefix, and a segment daemon whose sensor is that station's cloud names the cloud's frame
// (source.dds.frame_id), so that the segment's tf hangs the station's tree below its own
// fused frame: segment -> station0/lidarfuse/fused -> station0/lidar0, station0/lidar1, each
// frame with one parent. Here the segment has one station, its root, so that the chain is
// checked without registering stations to each other; in the segment's sensor world frame
// the station stays where it was first seen (within 2 cm / 0.1 deg).
TEST(DdsInputPipeline, AStationsTfTreeHangsBelowTheSegmentThatFusesItsCloud) {
    test::use_loopback_dds();
    test::TempDir dir("ddstf");
    DriverTopics drivers(dir.path(), "ddstf");
    ASSERT_NO_FATAL_FAILURE(drivers.simulate());
    const int domain = drivers.domain();
    const std::string dds = "dds: {domain_id: " + std::to_string(domain) + ", namespace: ";
    std::ofstream(dir.path() / "station.yaml")
        << "station: station0\nsensors:\n"
        << drivers.sensors_yaml() << "output: {directory: " << (dir.path() / "s0").string() << ", "
        << dds << "station0, frame_prefix: station0/}}\n";
    std::ofstream(dir.path() / "segment.yaml")
        << "station: segment\nsensors:\n"
        << "  - {name: station0, source: {dds: {topic: rt/station0/points, domain_id: " << domain
        << ", frame_id: station0/lidarfuse/fused}}}\n"
        << "world: {frame: sensor}\n"
        << "output: {directory: " << (dir.path() / "seg").string() << ", " << dds
        << "segment, frame_id: segment}}\n";
    Pipeline segment(load_daemon_config(dir.path() / "segment.yaml"));
    Pipeline station(load_daemon_config(dir.path() / "station.yaml"));
    dds_entity_t participant =
        dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    ASSERT_GT(participant, 0);
    test::DdsReader<tf2_msgs_msg_dds__TFMessage_> tf(
        participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", test::reader_qos(100));
    segment.start();
    station.start();
    ASSERT_NO_FATAL_FAILURE(drivers.open_for(&station));
    ASSERT_TRUE(test::eventually([&] { return segment.stats().sensors[0].dds->publishers > 0; }));
    TfTree tree;
    std::atomic<bool> publishing{true};
    std::thread listener([&] {
        while (publishing.load()) {
            tf.take([&](const tf2_msgs_msg_dds__TFMessage_& m) { tree.add(m); });
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    });
    drivers.publish();
    const PipelineStats station_stats = settled_stats(&station);
    const PipelineStats segment_stats = settled_stats(&segment);
    publishing.store(false);
    listener.join();
    tf.take([&](const tf2_msgs_msg_dds__TFMessage_& m) { tree.add(m); });
    station.stop();
    segment.stop();
    dds_delete(participant);
    if (!station_stats.sensors[1].pose_valid || segment_stats.frames_fused == 0) {
        GTEST_SKIP() << "the station's initial registration did not finish within the run ("
                     << segment_stats.frames_fused << " segment frames): a loaded machine or a "
                     << "sanitizer";
    }
    const std::string station_frame = "station0/lidarfuse/fused";
    EXPECT_EQ(segment_stats.sensors[0].dds->frame_id, station_frame);
    EXPECT_EQ(segment_stats.sensors[0].dds->refused, 0u);
    EXPECT_EQ(tree.parent(station_frame), "segment");
    EXPECT_EQ(tree.parent("station0/lidar0"), station_frame);
    EXPECT_EQ(tree.parent("station0/lidar1"), station_frame);
    EXPECT_FALSE(tree.parents.count("segment"));  // the top of the tree
    EXPECT_EQ(tree.parents.size(), 3u);           // no frame under another name
    ASSERT_TRUE(tree.newest.count(station_frame));
    const Eigen::Isometry3d& T_segment_station = tree.newest.at(station_frame);
    EXPECT_LT(T_segment_station.translation().norm(), 0.02);
    EXPECT_LT(core::rotation_error_deg(T_segment_station, Eigen::Isometry3d::Identity()), 0.1);
}

}  // namespace
}  // namespace lidarfuse::daemon
