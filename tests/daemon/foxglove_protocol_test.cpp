// The live view's protocol pieces without a network: the channels' ros2msg schemas, the
// JSON a client gets and sends, the binary message-data frame, and the CDR bytes of a
// sample as Cyclone writes them.
#include "daemon/foxglove_protocol.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "daemon/cdr_sample.hpp"
#include "daemon/foxglove_schemas.hpp"
#include "std_msgs.h"
#include "tests/support/test_data.hpp"

namespace lidarfuse::daemon {
namespace {

using ::testing::HasSubstr;

// The field lines of a .msg file: comments and blank lines dropped, same-package types
// given their package (as foxglove_schemas.cpp writes every type).
std::string msg_fields(const std::string& file, const std::string& package) {
    std::ifstream in(test::source_dir() / "ros2" / package / "msg" / file);
    std::string line, out;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        const bool qualified = line.find('/') != std::string::npos;
        const bool lower = line[0] >= 'a' && line[0] <= 'z';  // a primitive type
        out += (qualified || lower ? "" : package + "/") + line + "\n";
    }
    return out;
}

// The text of one definition inside a schema: from "MSG: <type>" to the next separator.
std::string dependency_text(const std::string& schema, const std::string& type) {
    const std::string head = "MSG: " + type + "\n";
    const auto begin = schema.find(head);
    if (begin == std::string::npos) return "";
    const auto end = schema.find("\n=", begin);
    return schema.substr(begin + head.size(), end == std::string::npos
                                                  ? std::string::npos
                                                  : end + 1 - begin - head.size());
}

TEST(FoxgloveSchemas, LidarfuseMsgsEqualTheRos2PackagesFiles) {
    const std::string poses = ros2msg_schema("lidarfuse_msgs/FramePoses");
    EXPECT_EQ(poses.substr(0, poses.find("====")), msg_fields("FramePoses.msg", "lidarfuse_msgs"));
    EXPECT_EQ(dependency_text(poses, "lidarfuse_msgs/SensorPose"),
              msg_fields("SensorPose.msg", "lidarfuse_msgs"));
}

// Foxglove resolves every type a schema names from the definitions after it: each one
// used, directly or not, is there once, after a line of 80 '='.
TEST(FoxgloveSchemas, EveryUsedTypeFollowsOnceAfterItsSeparator) {
    const std::string cloud = ros2msg_schema("sensor_msgs/PointCloud2");
    EXPECT_THAT(cloud, HasSubstr("sensor_msgs/PointField[] fields\n"));
    EXPECT_THAT(cloud, HasSubstr(std::string(80, '=') + "\nMSG: std_msgs/Header\n"));
    EXPECT_THAT(cloud, HasSubstr("\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"));
    EXPECT_THAT(cloud, HasSubstr("\nMSG: sensor_msgs/PointField\n"));
    const std::string tf = ros2msg_schema("tf2_msgs/TFMessage");
    for (const char* used :
         {"geometry_msgs/TransformStamped", "std_msgs/Header", "builtin_interfaces/Time",
          "geometry_msgs/Transform", "geometry_msgs/Vector3", "geometry_msgs/Quaternion"}) {
        const std::string head = "\nMSG: " + std::string(used) + "\n";
        const auto at = tf.find(head);
        ASSERT_NE(at, std::string::npos) << used;
        EXPECT_EQ(tf.find(head, at + 1), std::string::npos) << used << " twice";
        EXPECT_EQ(tf.substr(at - 80, 80), std::string(80, '=')) << used;
    }
}

TEST(FoxgloveProtocol, ServerInfoAndAdvertiseNameEveryChannel) {
    const auto info = nlohmann::json::parse(foxglove_server_info("lidarfused s", "17"));
    EXPECT_EQ(info["op"], "serverInfo");
    EXPECT_EQ(info["name"], "lidarfused s");
    EXPECT_EQ(info["sessionId"], "17");
    EXPECT_TRUE(info["capabilities"].empty());
    const auto channels = foxglove_channels("site/a");
    const auto ad = nlohmann::json::parse(foxglove_advertise(channels));
    EXPECT_EQ(ad["op"], "advertise");
    ASSERT_EQ(ad["channels"].size(), 5u);
    std::vector<std::string> topics;
    for (const auto& c : ad["channels"]) {
        topics.push_back(c["topic"]);
        EXPECT_EQ(c["encoding"], "cdr");
        EXPECT_EQ(c["schemaEncoding"], "ros2msg");
        EXPECT_THAT(c["schemaName"].get<std::string>(), HasSubstr("/msg/"));
        EXPECT_FALSE(c["schema"].get<std::string>().empty());
        EXPECT_GT(c["id"].get<int>(), 0);
    }
    EXPECT_THAT(topics, ::testing::ElementsAre("/site/a/points", "/tf", "/tf_static",
                                               "/diagnostics", "/site/a/poses"));
    EXPECT_EQ(foxglove_channels("")[0].topic, "/points");
    EXPECT_TRUE(channels[2].latched);
    // output.dds.points_voxel_size_m > 0: the thinned cloud as a sixth channel.
    const auto with_voxels = foxglove_channels("site/a", true);
    ASSERT_EQ(with_voxels.size(), kFoxgloveChannelCount);
    EXPECT_EQ(with_voxels.back().topic, "/site/a/points_voxel");
    EXPECT_EQ(with_voxels.back().id, FoxgloveChannel::kPointsVoxel);
    EXPECT_EQ(with_voxels.back().schema_name, with_voxels.front().schema_name);
}

TEST(FoxgloveProtocol, SubscribeAndUnsubscribeAreParsedAndBadRequestsSayWhy) {
    const auto sub = parse_foxglove_request(
        R"({"op":"subscribe","subscriptions":[{"id":0,"channelId":1},{"id":7,"channelId":5}]})");
    ASSERT_EQ(sub.kind, FoxgloveRequest::Kind::kSubscribe);
    EXPECT_THAT(sub.subscribe,
                ::testing::ElementsAre(std::make_pair(0u, 1u), std::make_pair(7u, 5u)));
    const auto unsub = parse_foxglove_request(R"({"op":"unsubscribe","subscriptionIds":[7]})");
    ASSERT_EQ(unsub.kind, FoxgloveRequest::Kind::kUnsubscribe);
    EXPECT_THAT(unsub.unsubscribe, ::testing::ElementsAre(7u));
    const std::pair<const char*, const char*> bad[] = {
        {"{", "not a JSON object"},
        {"[1]", "not a JSON object"},
        {R"({"op":"advertise","channels":[]})", "unsupported op \"advertise\""},
        {R"({"subscriptions":[]})", "no \"op\""},
        {R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})", "u32"},
        {R"({"op":"subscribe","subscriptions":[{"id":4294967296,"channelId":1}]})", "u32"},
        {R"({"op":"unsubscribe","subscriptionIds":"7"})", "no subscriptionIds array"},
    };
    for (const auto& [text, why] : bad) {
        const auto r = parse_foxglove_request(text);
        EXPECT_EQ(r.kind, FoxgloveRequest::Kind::kInvalid) << text;
        EXPECT_THAT(r.error, HasSubstr(why)) << text;
    }
}

TEST(FoxgloveProtocol, MessageDataFrameIsOpcodeSubscriptionTimeThenPayload) {
    std::string frame = "left over from a bigger message";
    foxglove_message_data(0x01020304u, 0x1122334455667788ull, {0xAA, 0xBB}, &frame);
    const std::string expected("\x01\x04\x03\x02\x01\x88\x77\x66\x55\x44\x33\x22\x11\xAA\xBB", 15);
    EXPECT_EQ(frame, expected);
}

// The bytes Cyclone's writer builds for a std_msgs/Header, behind CDR_LE's header:
// sec, nanosec, then the string with its length (NUL included) and the NUL.
TEST(CdrSampleWriter, WritesCycloneCdrBehindTheLittleEndianHeader) {
    CdrSampleWriter writer;
    char frame_id[] = "ab";
    std_msgs_msg_dds__Header_ header{};
    header.stamp.sec = 0x01020304;
    header.stamp.nanosec = 5;
    header.frame_id = frame_id;
    const auto bytes = writer.write(std_msgs_msg_dds__Header__desc, &header);
    const std::vector<std::uint8_t> expected = {0x00, 0x01, 0x00, 0x00, 0x04, 0x03, 0x02,
                                                0x01, 0x05, 0x00, 0x00, 0x00, 0x03, 0x00,
                                                0x00, 0x00, 'a',  'b',  0x00};
    EXPECT_EQ(*bytes, expected);
    // The stream is reused: a second sample starts again at the header.
    header.stamp.nanosec = 6;
    EXPECT_EQ((*writer.write(std_msgs_msg_dds__Header__desc, &header))[8], 6);
    EXPECT_EQ(bytes->at(8), 5) << "the first sample's bytes were changed";
}

}  // namespace
}  // namespace lidarfuse::daemon
