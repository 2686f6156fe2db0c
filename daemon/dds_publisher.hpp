#pragma once
// lidarfused's DDS output (Cyclone DDS C API), in ROS 2's DDS mapping so ROS 2 tools read
// it without a bridge:
//
//   rt/<ns>/points   sensor_msgs::msg::dds_::PointCloud2_        one per fused frame
//   rt/<ns>/points_voxel   the same, thinned to one point per voxel (points_voxel_size_m
//                    > 0 only; core/pipeline/fused_cloud_voxels.hpp), for consumers on
//                    slow links; thinned on the output thread, only while it is wanted
//   rt/<ns>/poses    lidarfuse_msgs::msg::dds_::FramePoses_      one per fused frame
//   rt/tf            tf2_msgs::msg::dds_::TFMessage_             one per fused frame with a
//                    registered sensor in it: T_fused_sensor of each such sensor (the root
//                    included), stamped with its scan's stamp (daemon/frame_stamps.hpp)
//   rt/tf_static     tf2_msgs::msg::dds_::TFMessage_             world.frame: geo only:
//                    <world.frame_id> -> fused frame (the geo offset), once
//   rt/diagnostics   diagnostic_msgs::msg::dds_::DiagnosticArray_
//
// The sensors move (the poles sway), so their transforms go on rt/tf only: tf2 drops a
// frame's history whenever it switches between rt/tf and rt/tf_static.
//
// QoS: keyless topics, XCDR1 (classic CDR, what ROS 2 uses), reliable with keep-last
// `depth` and a max_blocking_time of `max_blocking_ms`, so a subscriber that stops
// acknowledging costs at most that per write, never a stalled pipeline. USER_DATA holds
// the type hash as rmw_cyclonedds writes it (daemon/ros_type_hash.hpp). Writes never
// throw: failures (and timeouts among them) are counted.
//
// Live view: with mirror_to(server), every sample written is also handed to the Foxglove
// server (daemon/foxglove_server.hpp) as the CDR bytes Cyclone builds for it
// (daemon/cdr_sample.hpp), but only while a client is subscribed to its channel (or the
// channel is latched): no serialisation otherwise.
//
// Threads: construct and destroy on one thread; publish_* from one thread at a time (the
// output thread); counters() from any thread.

#include <dds/dds.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "core/pipeline/fused_cloud_voxels.hpp"
#include "core/pipeline/fusion_types.hpp"
#include "daemon/cdr_sample.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/dds_messages.hpp"
#include "daemon/foxglove_schemas.hpp"
#include "daemon/pipeline.hpp"

namespace lidarfuse::daemon {

class FoxgloveServer;

struct DdsCounters {
    std::uint64_t written = 0;   // samples accepted by dds_write
    std::uint64_t failures = 0;  // dds_write errors (timeouts included)
    std::uint64_t timeouts = 0;  // ... of which a reader held the writer past max_blocking_ms
    std::uint64_t clouds = 0, voxel_clouds = 0, tf = 0, tf_static = 0, poses = 0,
                  diagnostics = 0;       // written per topic
    std::uint64_t unstamped_frames = 0;  // frames without a stamped sensor: nothing sent
};

// The domain the publisher joins: the configured one, else $ROS_DOMAIN_ID, else 0. Throws
// std::runtime_error when ROS_DOMAIN_ID is set but not an integer in 0..232.
int resolve_domain_id(int configured, const char* ros_domain_id);

// "rt/" + namespace + "/" + leaf (ROS 2's topic prefix for plain topics).
std::string ros_topic_name(const std::string& topic_namespace, const std::string& leaf);

class DdsPublisher {
public:
    // Creates the participant, topics and writers; throws std::runtime_error naming the
    // domain and the topic when Cyclone refuses.
    // `static_parent_frame` non-empty (world.frame: geo): an rt/tf_static writer too
    // (transient-local, depth 1, as tf2_ros's static broadcaster) for publish_static().
    DdsPublisher(const DdsConfig& config, StationFrames frames,
                 std::string static_parent_frame = "");
    ~DdsPublisher();
    DdsPublisher(const DdsPublisher&) = delete;
    DdsPublisher& operator=(const DdsPublisher&) = delete;

    void publish_frame(const core::FrameOutput& frame, const FrameStamps& stamps);
    // The thinned cloud of the last publish_frame that published one (empty before).
    const core::FusedCloud& last_voxel_cloud() const { return voxel_cloud_; }
    void publish_diagnostics(const PipelineStats& stats, std::int64_t stamp_ns);
    // rt/tf_static: static_parent_frame -> the fused frame, T_parent_fused. Sent the first
    // time and again only when the transform changes; nothing without a static writer or
    // with a stamp that is not positive.
    void publish_static(const Eigen::Isometry3d& T_parent_fused, std::int64_t stamp_ns);

    // Mirror every sample to `server` (not owned; it outlives the publishing), or to none.
    // Before the output thread starts.
    void mirror_to(FoxgloveServer* server) { foxglove_ = server; }

    DdsCounters counters() const;
    int domain_id() const { return domain_id_; }

private:
    struct Counter {
        std::atomic<std::uint64_t> value{0};
    };
    // dds_write, counted, and the sample mirrored to the live view's `channel`.
    bool write(dds_entity_t writer, const dds_topic_descriptor_t& type, const void* sample,
               Counter* topic_counter, FoxgloveChannel channel);
    bool voxel_cloud_wanted() const;

    DdsConfig config_;
    StationFrames frames_;
    std::string static_parent_frame_;
    bool static_sent_ = false;
    Eigen::Isometry3d static_sent_pose_ = Eigen::Isometry3d::Identity();
    int domain_id_ = 0;
    dds_entity_t participant_ = 0;
    dds_entity_t points_writer_ = 0, poses_writer_ = 0, tf_writer_ = 0, diagnostics_writer_ = 0,
                 tf_static_writer_ = 0, voxel_writer_ = 0;
    FrameMessageBuilder frame_builder_;
    FrameMessageBuilder voxel_builder_;  // its own buffers: both clouds are written per frame
    core::FusedCloudVoxels voxels_;
    core::FusedCloud voxel_cloud_;
    DiagnosticsBuilder diagnostics_builder_;
    FoxgloveServer* foxglove_ = nullptr;
    CdrSampleWriter cdr_;
    Counter written_, failures_, timeouts_, clouds_, voxel_clouds_, tf_, tf_static_, poses_,
        diagnostics_, unstamped_;
};

}  // namespace lidarfuse::daemon
