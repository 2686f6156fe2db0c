#include "daemon/foxglove_schemas.hpp"

#include <map>
#include <stdexcept>

namespace lidarfuse::daemon {

namespace {

// One ROS 2 message type: its fields (ros2msg syntax, without comments; every type named
// with its package, so no reader has to guess one) and the types they name, in the order
// their definitions follow the message's own.
struct MessageDefinition {
    const char* fields;
    std::vector<std::string> uses;
};

// The ROS 2 Humble definitions of the types daemon/idl/ mirrors, and lidarfuse_msgs' from
// ros2/lidarfuse_msgs/msg/ (foxglove_schemas_test keeps them equal).
const std::map<std::string, MessageDefinition>& definitions() {
    static const std::map<std::string, MessageDefinition> kDefinitions = {
        {"builtin_interfaces/Time", {"int32 sec\nuint32 nanosec\n", {}}},
        {"std_msgs/Header",
         {"builtin_interfaces/Time stamp\nstring frame_id\n", {"builtin_interfaces/Time"}}},
        {"sensor_msgs/PointField",
         {"uint8 INT8 = 1\nuint8 UINT8 = 2\nuint8 INT16 = 3\nuint8 UINT16 = 4\nuint8 INT32 = 5\n"
          "uint8 UINT32 = 6\nuint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\n"
          "string name\nuint32 offset\nuint8 datatype\nuint32 count\n",
          {}}},
        {"sensor_msgs/PointCloud2",
         {"std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\n"
          "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
          {"std_msgs/Header", "sensor_msgs/PointField"}}},
        {"geometry_msgs/Vector3", {"float64 x\nfloat64 y\nfloat64 z\n", {}}},
        {"geometry_msgs/Quaternion", {"float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n", {}}},
        {"geometry_msgs/Transform",
         {"geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n",
          {"geometry_msgs/Vector3", "geometry_msgs/Quaternion"}}},
        {"geometry_msgs/TransformStamped",
         {"std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
          {"std_msgs/Header", "geometry_msgs/Transform"}}},
        {"tf2_msgs/TFMessage",
         {"geometry_msgs/TransformStamped[] transforms\n", {"geometry_msgs/TransformStamped"}}},
        {"diagnostic_msgs/KeyValue", {"string key\nstring value\n", {}}},
        {"diagnostic_msgs/DiagnosticStatus",
         {"byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n"
          "byte level\nstring name\nstring message\nstring hardware_id\ndiagnostic_msgs/KeyValue[] "
          "values\n",
          {"diagnostic_msgs/KeyValue"}}},
        {"diagnostic_msgs/DiagnosticArray",
         {"std_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status\n",
          {"std_msgs/Header", "diagnostic_msgs/DiagnosticStatus"}}},
        {"lidarfuse_msgs/SensorPose",
         {"string name\nbuiltin_interfaces/Time stamp\ngeometry_msgs/Transform transform\n"
          "bool included\nbool pose_valid\nstring track_state\nfloat64 fitness\n",
          {"builtin_interfaces/Time", "geometry_msgs/Transform"}}},
        {"lidarfuse_msgs/FramePoses",
         {"std_msgs/Header header\nint64 frame_index\nstring "
          "root_sensor\nlidarfuse_msgs/SensorPose[] sensors\n",
          {"std_msgs/Header", "lidarfuse_msgs/SensorPose"}}},
    };
    return kDefinitions;
}

const MessageDefinition& definition(const std::string& type_name) {
    const auto it = definitions().find(type_name);
    if (it == definitions().end()) throw std::logic_error("no ros2msg definition of " + type_name);
    return it->second;
}

// Every type `type_name` uses, directly or not, each once, depth first.
void collect_dependencies(const std::string& type_name, std::vector<std::string>* out) {
    for (const auto& used : definition(type_name).uses) {
        bool seen = false;
        for (const auto& s : *out) seen = seen || s == used;
        if (seen) continue;
        out->push_back(used);
        collect_dependencies(used, out);
    }
}

// "sensor_msgs/PointCloud2" -> "sensor_msgs/msg/PointCloud2" (the channel's schemaName).
std::string ros2_type_name(const std::string& type_name) {
    const auto slash = type_name.find('/');
    return type_name.substr(0, slash) + "/msg" + type_name.substr(slash);
}

}  // namespace

std::string ros2msg_schema(const std::string& type_name) {
    std::string text = definition(type_name).fields;
    std::vector<std::string> dependencies;
    collect_dependencies(type_name, &dependencies);
    for (const auto& d : dependencies) {
        text += std::string(80, '=') + "\nMSG: " + d + "\n" + definition(d).fields;
    }
    return text;
}

std::vector<FoxgloveChannelInfo> foxglove_channels(const std::string& topic_namespace,
                                                   bool points_voxel) {
    const std::string prefix = topic_namespace.empty() ? "/" : "/" + topic_namespace + "/";
    const auto channel = [](FoxgloveChannel id, std::string topic, const std::string& type,
                            bool latched = false) {
        return FoxgloveChannelInfo{id, std::move(topic), ros2_type_name(type), ros2msg_schema(type),
                                   latched};
    };
    std::vector<FoxgloveChannelInfo> channels = {
        channel(FoxgloveChannel::kPoints, prefix + "points", "sensor_msgs/PointCloud2"),
        channel(FoxgloveChannel::kTf, "/tf", "tf2_msgs/TFMessage"),
        channel(FoxgloveChannel::kTfStatic, "/tf_static", "tf2_msgs/TFMessage", true),
        channel(FoxgloveChannel::kDiagnostics, "/diagnostics", "diagnostic_msgs/DiagnosticArray"),
        channel(FoxgloveChannel::kPoses, prefix + "poses", "lidarfuse_msgs/FramePoses")};
    if (points_voxel) {
        channels.push_back(channel(FoxgloveChannel::kPointsVoxel, prefix + "points_voxel",
                                   "sensor_msgs/PointCloud2"));
    }
    return channels;
}

}  // namespace lidarfuse::daemon
