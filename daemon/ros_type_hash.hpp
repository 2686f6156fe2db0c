#pragma once
// ROS 2 type hashes (REP 2011, "RIHS01"), as rosidl computes them at build time and as
// rmw_cyclonedds announces them in every writer's USER_DATA QoS (`typehash=RIHS01_<hex>;`).
// ROS 2 Jazzy and later parse that string for every discovered endpoint; without it they
// log a parse failure per writer and cannot check that both sides agree on the type.
//
// RIHS01 = sha256 over a canonical JSON of type_description_interfaces/TypeDescription:
// {"type_description": T, "referenced_type_descriptions": [R...]} with every type T
// referenced directly or indirectly listed once, sorted by name; each type as
// {"type_name": "pkg/msg/Name", "fields": [{"name", "type": {"type_id", "capacity",
// "string_capacity", "nested_type_name"}}]} (default values are left out of the hash),
// written with ", " and ": " separators and no other whitespace.

#include <cstdint>
#include <string>
#include <vector>

namespace lidarfuse::daemon {

// type_description_interfaces/msg/FieldType ids (the subset ROS messages here use).
// A fixed array adds 48, a bounded sequence 96, an unbounded sequence 144.
enum RosFieldType : std::uint8_t {
    kRosNested = 1,
    kRosInt8 = 2,
    kRosUint8 = 3,
    kRosInt16 = 4,
    kRosUint16 = 5,
    kRosInt32 = 6,
    kRosUint32 = 7,
    kRosInt64 = 8,
    kRosUint64 = 9,
    kRosFloat32 = 10,
    kRosFloat64 = 11,
    kRosBool = 15,
    kRosByte = 16,
    kRosString = 17,
};
inline constexpr std::uint8_t kRosUnboundedSequence = 144;

struct RosField {
    std::string name;
    int type_id = 0;                    // RosFieldType, plus kRosUnboundedSequence for `T[]`
    std::string nested_type_name;       // "pkg/msg/Name" for nested types, else ""
    std::uint64_t capacity = 0;         // fixed array size
    std::uint64_t string_capacity = 0;  // bounded string size
};

struct RosTypeDescription {
    std::string type_name;  // "pkg/msg/Name"
    std::vector<RosField> fields;
};

// Every type lidarfused publishes and every type they reference: the canonical ROS 2
// definitions (common_interfaces) and lidarfuse_msgs (ros2/lidarfuse_msgs/msg/).
const std::vector<RosTypeDescription>& published_ros_types();

// The canonical JSON rosidl hashes for `type_name`, its referenced types taken from
// `types`. Throws std::invalid_argument naming a type that is not in `types`.
std::string ros_type_description_json(const std::string& type_name,
                                      const std::vector<RosTypeDescription>& types);

// "RIHS01_" + 64 lowercase hex digits.
std::string ros_type_hash(const std::string& type_name,
                          const std::vector<RosTypeDescription>& types = published_ros_types());

// "sensor_msgs::msg::dds_::PointCloud2_" -> "sensor_msgs/msg/PointCloud2" (ROS 2's DDS
// mapping reversed); "" when the name does not follow that mapping.
std::string ros_type_name_from_dds(const std::string& dds_type_name);

// USER_DATA of a writer of that DDS type, exactly as rmw_cyclonedds_cpp writes it:
// "typehash=RIHS01_<hex>;" (81 bytes, no terminator).
std::string ros_type_hash_user_data(const std::string& dds_type_name);

}  // namespace lidarfuse::daemon
