#pragma once
// FusionEngine results and pipeline statistics as ROS 2 messages on DDS (the C structs idlc
// generates from daemon/idl/). The builders own every buffer the C structs point into and
// reuse them from one message to the next, so a message stays valid until the builder's
// next call, and the steady state allocates nothing per frame. Not thread safe: one
// builder per thread (the output thread).
//
// Conventions (ROS 2): stamps are ns split into sec/nanosec; a transform
// T_parent_child has header.frame_id = parent, child_frame_id = child; PointCloud2 is
// little endian, one row (height 1), fields x, y, z, intensity (float32), sensor_id and
// dynamic (uint8), point_step 20 (two bytes of padding keep every float 4-byte aligned).

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "core/common/counter_field.hpp"
#include "core/pipeline/fusion_types.hpp"
#include "daemon/frame_stamps.hpp"
#include "daemon/pipeline.hpp"
#include "diagnostic_msgs.h"
#include "lidarfuse_msgs.h"
#include "sensor_msgs.h"
#include "tf2_msgs.h"

namespace lidarfuse::daemon {

inline constexpr std::uint32_t kPointStep = 20;
inline constexpr std::uint32_t kOffsetX = 0, kOffsetY = 4, kOffsetZ = 8, kOffsetIntensity = 12,
                               kOffsetSensorId = 16, kOffsetDynamic = 17;

builtin_interfaces_msg_dds__Time_ to_ros_time(std::int64_t t_ns);
std::int64_t from_ros_time(const builtin_interfaces_msg_dds__Time_& t);
geometry_msgs_msg_dds__Transform_ to_ros_transform(const Eigen::Isometry3d& T);
Eigen::Isometry3d from_ros_transform(const geometry_msgs_msg_dds__Transform_& t);

// Names and frames every message of one station uses.
struct StationFrames {
    std::string station;
    std::string fused_frame;                // header.frame_id of clouds, tf and poses
    std::vector<std::string> sensor_names;  // config order; the poses' names
    std::size_t root = 0;
    // Config order: child_frame_id of tf (daemon_config.hpp, sensor_frames_of); empty: the
    // names.
    std::vector<std::string> sensor_frames = {};
};

// Messages of one fused frame, every stamp from daemon/frame_stamps.hpp.
class FrameMessageBuilder {
public:
    // Throws std::invalid_argument when the fused frame is also a sensor's frame (tf2 would
    // see that sensor as its own parent; the config check refuses such a config first).
    explicit FrameMessageBuilder(StationFrames frames);

    // The fused cloud in the fused frame, stamped with the frame's stamp.
    const sensor_msgs_msg_dds__PointCloud2_& cloud(const core::FrameOutput& frame,
                                                   const FrameStamps& stamps) {
        return cloud(frame.cloud, stamps);
    }
    // The same message for another cloud of this frame (e.g. the thinned one).
    const sensor_msgs_msg_dds__PointCloud2_& cloud(const core::FusedCloud& cloud,
                                                   const FrameStamps& stamps);
    // rt/tf: T_fused_sensor of every sensor, the root included, that has a valid pose and a
    // scan in this frame, stamped with that scan's stamp. The others are left out (never a
    // stamp 0); the message may hold no transform, which the publisher does not send.
    const tf2_msgs_msg_dds__TFMessage_& tf(const core::FrameOutput& frame,
                                           const FrameStamps& stamps);
    // rt/<ns>/poses: every sensor; one not in this frame (a predicted pose) carries the
    // frame's stamp.
    const lidarfuse_msgs_msg_dds__FramePoses_& poses(const core::FrameOutput& frame,
                                                     const FrameStamps& stamps);

private:
    StationFrames frames_;
    std::vector<std::uint8_t> cloud_data_;
    sensor_msgs_msg_dds__PointField_ fields_[6];
    sensor_msgs_msg_dds__PointCloud2_ cloud_{};
    std::vector<geometry_msgs_msg_dds__TransformStamped_> transforms_;
    tf2_msgs_msg_dds__TFMessage_ tf_{};
    std::vector<lidarfuse_msgs_msg_dds__SensorPose_> sensor_poses_;
    lidarfuse_msgs_msg_dds__FramePoses_ poses_{};
};

// rt/diagnostics: one DiagnosticStatus per sensor (level OK, WARN when STALE or when fusing
// without a pose for it, ERROR when LOST) and one for the pipeline as a whole.
class DiagnosticsBuilder {
public:
    explicit DiagnosticsBuilder(StationFrames frames);
    const diagnostic_msgs_msg_dds__DiagnosticArray_& build(const PipelineStats& stats,
                                                           std::int64_t stamp_ns);

private:
    using KeyValues = std::vector<diagnostic_msgs_msg_dds__KeyValue_>;
    void add(KeyValues* values, const char* key, std::string value);
    // Every counter of `record`'s table, in the table's order.
    template <class Record, std::size_t N>
    void add_counters(KeyValues* values, const std::array<core::CounterField<Record>, N>& table,
                      const Record& record) {
        for (const auto& counter : table)
            add(values, counter.name, std::to_string(record.*counter.member));
    }
    // Level, name, message and hardware id of one status.
    void set_status(diagnostic_msgs_msg_dds__DiagnosticStatus_* status, std::uint8_t level,
                    std::string name, std::string message, std::string hardware_id);
    void add_sensor(diagnostic_msgs_msg_dds__DiagnosticStatus_* status, KeyValues* values,
                    const SensorStats& sensor, bool fusing);
    void add_sensor_values(KeyValues* values, const SensorStats& sensor);
    void add_dds_input_values(KeyValues* values, const DdsInputStatus& input);
    void add_pipeline(diagnostic_msgs_msg_dds__DiagnosticStatus_* status, KeyValues* values,
                      const PipelineStats& stats);
    void add_record(KeyValues* values, const RecorderStats& record);
    void add_foxglove(KeyValues* values, const FoxgloveStats& foxglove);
    // Points every status at its values.
    void point_values();

    StationFrames frames_;
    std::string prefix_;  // of every status name: "lidarfuse/<station>/"
    // Strings of the current message; the C structs point into them. A deque never moves
    // its elements, so pointers stay valid while more are added (rebuilt at every call,
    // about once a second).
    std::deque<std::string> strings_;
    std::vector<std::vector<diagnostic_msgs_msg_dds__KeyValue_>> values_;
    std::vector<diagnostic_msgs_msg_dds__DiagnosticStatus_> status_;
    diagnostic_msgs_msg_dds__DiagnosticArray_ array_{};
};

}  // namespace lidarfuse::daemon
