#pragma once
// The Foxglove live view's channels (daemon/foxglove_server.hpp): one per DDS topic the
// daemon writes, each with its ROS 2 type and the type's full `ros2msg` definition, the
// way Foxglove reads a channel it has no ROS install for: the message's own fields, then
// every type it uses, each after a line of 80 '=' and a "MSG: package/Type" line.

#include <cstdint>
#include <string>
#include <vector>

namespace lidarfuse::daemon {

// Channel ids as advertised; 0 is never a channel.
enum class FoxgloveChannel : std::uint32_t {
    kPoints = 1,
    kTf = 2,
    kTfStatic = 3,
    kDiagnostics = 4,
    kPoses = 5,
    kPointsVoxel = 6
};
inline constexpr std::size_t kFoxgloveChannelCount = 6;

struct FoxgloveChannelInfo {
    FoxgloveChannel id;
    std::string topic;        // e.g. /lidarfuse/points (the DDS topic without rt/)
    std::string schema_name;  // e.g. sensor_msgs/msg/PointCloud2
    std::string schema;       // ros2msg text with its dependencies
    bool latched = false;     // the last message goes to every new subscriber (/tf_static)
};

// The five channels, and with `points_voxel` (output.dds.points_voxel_size_m > 0) the
// thinned cloud's as a sixth; `topic_namespace` as output.dds.namespace ("" puts the clouds
// and poses at /points and /poses, as DDS does at rt/points).
std::vector<FoxgloveChannelInfo> foxglove_channels(const std::string& topic_namespace,
                                                   bool points_voxel = false);

// One type's schema: its definition, then each dependency's as Foxglove expects them.
// Exposed for the test that compares lidarfuse_msgs' with ros2/lidarfuse_msgs/msg/.
std::string ros2msg_schema(const std::string& type_name);

}  // namespace lidarfuse::daemon
