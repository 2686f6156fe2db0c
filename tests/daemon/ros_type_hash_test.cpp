// REP 2011 type hashes of every published type, against the values ROS 2 Jazzy's rosidl
// computes from the canonical .msg files, and USER_DATA exactly as rmw_cyclonedds writes it.
#include "daemon/ros_type_hash.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace lidarfuse::daemon {
namespace {

TEST(RosTypeHash, EqualsRosidlsForTheCanonicalTypes) {
    EXPECT_EQ(ros_type_hash("sensor_msgs/msg/PointCloud2"),
              "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5");
    EXPECT_EQ(ros_type_hash("std_msgs/msg/Header"),
              "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01");
    EXPECT_EQ(ros_type_hash("tf2_msgs/msg/TFMessage"),
              "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087");
    EXPECT_EQ(ros_type_hash("geometry_msgs/msg/TransformStamped"),
              "RIHS01_0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206");
    EXPECT_EQ(ros_type_hash("diagnostic_msgs/msg/DiagnosticArray"),
              "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e");
}

// The canonical form: referenced types sorted by name, each once, no default values.
TEST(RosTypeHash, DescriptionJsonIsRosidlsCanonicalForm) {
    EXPECT_EQ(ros_type_description_json("std_msgs/msg/Header", published_ros_types()),
              "{\"type_description\": {\"type_name\": \"std_msgs/msg/Header\", \"fields\": ["
              "{\"name\": \"stamp\", \"type\": {\"type_id\": 1, \"capacity\": 0, "
              "\"string_capacity\": 0, \"nested_type_name\": \"builtin_interfaces/msg/Time\"}}, "
              "{\"name\": \"frame_id\", \"type\": {\"type_id\": 17, \"capacity\": 0, "
              "\"string_capacity\": 0, \"nested_type_name\": \"\"}}]}, "
              "\"referenced_type_descriptions\": [{\"type_name\": \"builtin_interfaces/msg/Time\", "
              "\"fields\": [{\"name\": \"sec\", \"type\": {\"type_id\": 6, \"capacity\": 0, "
              "\"string_capacity\": 0, \"nested_type_name\": \"\"}}, {\"name\": \"nanosec\", "
              "\"type\": {\"type_id\": 7, \"capacity\": 0, \"string_capacity\": 0, "
              "\"nested_type_name\": \"\"}}]}]}");
    const std::string json =
        ros_type_description_json("tf2_msgs/msg/TFMessage", published_ros_types());
    const auto at = [&](const char* name) {
        return json.find(std::string("\"type_name\": \"") + name);
    };
    EXPECT_LT(at("builtin_interfaces/msg/Time"), at("geometry_msgs/msg/Quaternion"));
    EXPECT_LT(at("geometry_msgs/msg/Quaternion"), at("geometry_msgs/msg/Transform\""));
    EXPECT_LT(at("geometry_msgs/msg/Vector3"), at("std_msgs/msg/Header"));
    EXPECT_EQ(json.find("Header", at("std_msgs/msg/Header") + 30), std::string::npos);
}

TEST(RosTypeHash, UnknownTypeIsNamed) {
    try {
        ros_type_hash("std_msgs/msg/String");
        FAIL() << "no exception";
    } catch (const std::invalid_argument& error) {
        EXPECT_NE(std::string(error.what()).find("std_msgs/msg/String"), std::string::npos);
    }
}

TEST(RosTypeHash, UserDataAsRmwCycloneddsWritesIt) {
    const std::string u = ros_type_hash_user_data("tf2_msgs::msg::dds_::TFMessage_");
    EXPECT_EQ(u,
              "typehash=RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087;");
    EXPECT_EQ(u.size(), 81u);
    EXPECT_EQ(ros_type_name_from_dds("diagnostic_msgs::msg::dds_::DiagnosticArray_"),
              "diagnostic_msgs/msg/DiagnosticArray");
    EXPECT_EQ(ros_type_name_from_dds("lidarfuse_msgs::msg::dds_::FramePoses_"),
              "lidarfuse_msgs/msg/FramePoses");
    EXPECT_EQ(ros_type_name_from_dds("sensor_msgs::msg::PointCloud2"), "");
    EXPECT_THROW(ros_type_hash_user_data("Plain"), std::invalid_argument);
}

}  // namespace
}  // namespace lidarfuse::daemon
