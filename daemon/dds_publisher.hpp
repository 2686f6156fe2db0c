#pragma once
// lidarfused's DDS output (Cyclone DDS C API), in ROS 2's DDS mapping so ROS 2 tools read
// it without a bridge:
//
//   rt/<ns>/points   sensor_msgs::msg::dds_::PointCloud2_        one per fused frame
//   rt/<ns>/poses    lidarfuse_msgs::msg::dds_::FramePoses_      one per fused frame
//   rt/tf            tf2_msgs::msg::dds_::TFMessage_             one per fused frame, every
//                    registered sensor's T_fused_sensor stamped with its scan time
//   rt/tf_static     tf2_msgs::msg::dds_::TFMessage_             transient-local, depth 1:
//                    once every sensor present is registered, again when a pose moved more
//                    than static_update_m / static_update_deg, or a sensor got registered
//   rt/diagnostics   diagnostic_msgs::msg::dds_::DiagnosticArray_
//
// QoS: keyless topics, XCDR1 (classic CDR, what ROS 2 uses), reliable with keep-last
// `depth` and a max_blocking_time of `max_blocking_ms`, so a subscriber that stops
// acknowledging costs at most that per write, never a stalled pipeline. Writes never
// throw: failures (and timeouts among them) are counted.
//
// Threads: construct and destroy on one thread; publish_* from one thread at a time (the
// output thread); counters() from any thread.

#include <dds/dds.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "core/pipeline/fusion_types.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/dds_messages.hpp"
#include "daemon/pipeline.hpp"

namespace lidarfuse::daemon {

struct DdsCounters {
    std::uint64_t written = 0;   // samples accepted by dds_write
    std::uint64_t failures = 0;  // dds_write errors (timeouts included)
    std::uint64_t timeouts = 0;  // ... of which a reader held the writer past max_blocking_ms
    std::uint64_t clouds = 0, tf = 0, tf_static = 0, poses = 0,
                  diagnostics = 0;  // written per topic
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
    DdsPublisher(const DdsConfig& config, StationFrames frames);
    ~DdsPublisher();
    DdsPublisher(const DdsPublisher&) = delete;
    DdsPublisher& operator=(const DdsPublisher&) = delete;

    void publish_frame(const core::FrameOutput& frame);
    void publish_diagnostics(const PipelineStats& stats, std::int64_t stamp_ns);

    DdsCounters counters() const;
    int domain_id() const { return domain_id_; }

private:
    struct Counter {
        std::atomic<std::uint64_t> value{0};
    };
    bool write(dds_entity_t writer, const void* sample, Counter* topic_counter);
    bool static_transforms_changed(const core::FrameOutput& frame) const;

    DdsConfig config_;
    StationFrames frames_;
    int domain_id_ = 0;
    dds_entity_t participant_ = 0;
    dds_entity_t points_writer_ = 0, poses_writer_ = 0, tf_writer_ = 0, tf_static_writer_ = 0,
                 diagnostics_writer_ = 0;
    FrameMessageBuilder frame_builder_;
    FrameMessageBuilder static_builder_;
    DiagnosticsBuilder diagnostics_builder_;
    // The poses last sent on rt/tf_static (output thread only).
    std::vector<Eigen::Isometry3d> static_T_;
    std::vector<bool> static_valid_;
    bool static_pending_ = false;
    Counter written_, failures_, timeouts_, clouds_, tf_, tf_static_, poses_, diagnostics_;
};

}  // namespace lidarfuse::daemon
