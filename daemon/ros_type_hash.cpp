#include "daemon/ros_type_hash.hpp"

#include <openssl/evp.h>

#include <array>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>

namespace lidarfuse::daemon {

namespace {

RosField field(std::string name, int type_id, std::string nested = {}) {
    RosField f;
    f.name = std::move(name);
    f.type_id = type_id;
    f.nested_type_name = std::move(nested);
    return f;
}

RosField nested(std::string name, std::string type, bool sequence = false) {
    return field(std::move(name), kRosNested + (sequence ? kRosUnboundedSequence : 0),
                 std::move(type));
}

// The fields of the canonical .msg files, in their order (common_interfaces for ROS 2
// Jazzy; builtin_interfaces from rcl_interfaces). Constants are not part of a type
// description, so PointField's datatypes and DiagnosticStatus's levels do not appear.
std::vector<RosTypeDescription> make_published_types() {
    const std::string time = "builtin_interfaces/msg/Time", header = "std_msgs/msg/Header";
    return {
        {time, {field("sec", kRosInt32), field("nanosec", kRosUint32)}},
        {header, {nested("stamp", time), field("frame_id", kRosString)}},
        {"geometry_msgs/msg/Vector3",
         {field("x", kRosFloat64), field("y", kRosFloat64), field("z", kRosFloat64)}},
        {"geometry_msgs/msg/Quaternion",
         {field("x", kRosFloat64), field("y", kRosFloat64), field("z", kRosFloat64),
          field("w", kRosFloat64)}},
        {"geometry_msgs/msg/Transform",
         {nested("translation", "geometry_msgs/msg/Vector3"),
          nested("rotation", "geometry_msgs/msg/Quaternion")}},
        {"geometry_msgs/msg/TransformStamped",
         {nested("header", header), field("child_frame_id", kRosString),
          nested("transform", "geometry_msgs/msg/Transform")}},
        {"tf2_msgs/msg/TFMessage",
         {nested("transforms", "geometry_msgs/msg/TransformStamped", true)}},
        {"sensor_msgs/msg/PointField",
         {field("name", kRosString), field("offset", kRosUint32), field("datatype", kRosUint8),
          field("count", kRosUint32)}},
        {"sensor_msgs/msg/PointCloud2",
         {nested("header", header), field("height", kRosUint32), field("width", kRosUint32),
          nested("fields", "sensor_msgs/msg/PointField", true), field("is_bigendian", kRosBool),
          field("point_step", kRosUint32), field("row_step", kRosUint32),
          field("data", kRosUint8 + kRosUnboundedSequence), field("is_dense", kRosBool)}},
        {"diagnostic_msgs/msg/KeyValue", {field("key", kRosString), field("value", kRosString)}},
        {"diagnostic_msgs/msg/DiagnosticStatus",
         {field("level", kRosByte), field("name", kRosString), field("message", kRosString),
          field("hardware_id", kRosString),
          nested("values", "diagnostic_msgs/msg/KeyValue", true)}},
        {"diagnostic_msgs/msg/DiagnosticArray",
         {nested("header", header),
          nested("status", "diagnostic_msgs/msg/DiagnosticStatus", true)}},
        {"lidarfuse_msgs/msg/SensorPose",
         {field("name", kRosString), nested("stamp", time),
          nested("transform", "geometry_msgs/msg/Transform"), field("included", kRosBool),
          field("pose_valid", kRosBool), field("track_state", kRosString),
          field("fitness", kRosFloat64)}},
        {"lidarfuse_msgs/msg/FramePoses",
         {nested("header", header), field("frame_index", kRosInt64),
          field("root_sensor", kRosString),
          nested("sensors", "lidarfuse_msgs/msg/SensorPose", true)}},
    };
}

// A JSON string as Python's json.dumps(ensure_ascii=True) writes it.
std::string json_string(const std::string& s) {
    std::string out = "\"";
    for (const char ch : s) {
        const auto c = static_cast<unsigned char>(ch);
        if (c == '"' || c == '\\') {
            out += '\\';
            out += ch;
        } else if (c < 0x20 || c >= 0x7f) {
            char buffer[8];
            std::snprintf(buffer, sizeof(buffer), "\\u%04x", c);
            out += buffer;
        } else {
            out += ch;
        }
    }
    return out + "\"";
}

std::string json_type(const RosTypeDescription& t) {
    std::string out = "{\"type_name\": " + json_string(t.type_name) + ", \"fields\": [";
    for (std::size_t i = 0; i < t.fields.size(); ++i) {
        const RosField& f = t.fields[i];
        if (i > 0) out += ", ";
        out += "{\"name\": " + json_string(f.name) +
               ", \"type\": {\"type_id\": " + std::to_string(f.type_id) +
               ", \"capacity\": " + std::to_string(f.capacity) +
               ", \"string_capacity\": " + std::to_string(f.string_capacity) +
               ", \"nested_type_name\": " + json_string(f.nested_type_name) + "}}";
    }
    return out + "]}";
}

const RosTypeDescription& find_type(const std::map<std::string, const RosTypeDescription*>& by_name,
                                    const std::string& name) {
    const auto it = by_name.find(name);
    if (it == by_name.end()) throw std::invalid_argument("ROS type " + name + " is not described");
    return *it->second;
}

}  // namespace

const std::vector<RosTypeDescription>& published_ros_types() {
    static const std::vector<RosTypeDescription> kTypes = make_published_types();
    return kTypes;
}

std::string ros_type_description_json(const std::string& type_name,
                                      const std::vector<RosTypeDescription>& types) {
    std::map<std::string, const RosTypeDescription*> by_name;
    for (const auto& t : types) by_name[t.type_name] = &t;
    const RosTypeDescription& top = find_type(by_name, type_name);
    // Every type reachable from the top one; std::set keeps them sorted by name.
    std::set<std::string> referenced;
    std::vector<const RosTypeDescription*> pending = {&top};
    while (!pending.empty()) {
        const RosTypeDescription* t = pending.back();
        pending.pop_back();
        for (const auto& f : t->fields) {
            if (f.nested_type_name.empty() || !referenced.insert(f.nested_type_name).second)
                continue;
            pending.push_back(&find_type(by_name, f.nested_type_name));
        }
    }
    std::string out =
        "{\"type_description\": " + json_type(top) + ", \"referenced_type_descriptions\": [";
    bool first = true;
    for (const auto& name : referenced) {
        if (!first) out += ", ";
        first = false;
        out += json_type(find_type(by_name, name));
    }
    return out + "]}";
}

std::string ros_type_hash(const std::string& type_name,
                          const std::vector<RosTypeDescription>& types) {
    const std::string json = ros_type_description_json(type_name, types);
    std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
    unsigned int length = 0;
    if (EVP_Digest(json.data(), json.size(), digest.data(), &length, EVP_sha256(), nullptr) != 1)
        throw std::runtime_error("EVP_Digest(sha256) failed");
    std::string out = "RIHS01_";
    for (unsigned int i = 0; i < length; ++i) {
        char hex[3];
        std::snprintf(hex, sizeof(hex), "%02x", digest[i]);
        out += hex;
    }
    return out;
}

std::string ros_type_name_from_dds(const std::string& dds_type_name) {
    const std::string marker = "::msg::dds_::";
    const auto at = dds_type_name.find(marker);
    if (at == std::string::npos || at == 0 || dds_type_name.back() != '_') return {};
    const std::string package = dds_type_name.substr(0, at);
    const std::string name =
        dds_type_name.substr(at + marker.size(), dds_type_name.size() - at - marker.size() - 1);
    if (name.empty() || package.find(':') != std::string::npos ||
        name.find(':') != std::string::npos) {
        return {};
    }
    return package + "/msg/" + name;
}

std::string ros_type_hash_user_data(const std::string& dds_type_name) {
    const std::string ros_name = ros_type_name_from_dds(dds_type_name);
    if (ros_name.empty())
        throw std::invalid_argument(dds_type_name + " does not follow ROS 2's DDS type naming");
    return "typehash=" + ros_type_hash(ros_name) + ";";
}

}  // namespace lidarfuse::daemon
