// DdsPublisher against plain Cyclone readers in this process: ROS 2 type and topic names,
// the writers' QoS and type hash as discovered, message contents round trip, tf without
// stamp 0 or empty messages, and a reader that stops taking never holding the writer.
#include "daemon/dds_publisher.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>

#include "daemon/ros_type_hash.hpp"
#include "tests/daemon/dds_test_support.hpp"

namespace lidarfuse::daemon {
namespace {

using test::DdsReader;

constexpr double kPi = 3.14159265358979323846;

StationFrames frames3() { return {"test", "station", {"north", "east", "south"}, 0}; }

FrameStamps sensor_stamps(const core::FrameOutput& f) {
    return frame_stamps(f, StampSource::kSensor, {});
}

Eigen::Isometry3d pose(double x, double y, double z, double yaw_deg) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(x, y, z);
    T.linear() =
        Eigen::AngleAxisd(yaw_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return T;
}

core::FrameOutput frame(std::int64_t index, std::size_t points) {
    core::FrameOutput f;
    f.frame_index = index;
    f.T_root_sensor = {Eigen::Isometry3d::Identity(), pose(10, -2, 0.5, 30), pose(-4, 8, 1, -120)};
    const std::int64_t t0 = 1'763'700'000'000'000'000LL + index * 50'000'000LL;
    f.t_ns = {t0, t0 + 1'234'567, t0 + 2'000'001};
    f.health.resize(3);
    for (auto& h : f.health) {
        h.state = core::TrackState::kTracking;
        h.included = true;
        h.pose_valid = true;
        h.fitness_reference = 0.75;
    }
    f.health[2].included = false;
    f.health[2].state = core::TrackState::kMissing;
    for (std::size_t i = 0; i < points; ++i) {
        const float v = static_cast<float>(i);
        f.cloud.points.emplace_back(v * 0.5f, -v, v * 0.25f + 0.125f);
        f.cloud.intensity.push_back(v * 2.0f);
        f.cloud.sensor.push_back(static_cast<std::uint8_t>(i % 3));
        f.cloud.dynamic.push_back(static_cast<std::uint8_t>(i % 7 == 0));
    }
    return f;
}

// Point i of a PointCloud2 in the daemon's layout (dds_messages.hpp).
struct CloudPoint {
    float xyz[3];
    float intensity;
    std::uint8_t sensor, dynamic;
};
CloudPoint point_at(const sensor_msgs_msg_dds__PointCloud2_& m, std::size_t i) {
    const std::uint8_t* p = m.data._buffer + i * kPointStep;
    CloudPoint out{};
    std::memcpy(out.xyz, p + kOffsetX, sizeof(out.xyz));
    std::memcpy(&out.intensity, p + kOffsetIntensity, sizeof(float));
    out.sensor = p[kOffsetSensorId];
    out.dynamic = p[kOffsetDynamic];
    return out;
}

// USER_DATA of the one writer matched with `reader`, and its type's name.
std::pair<std::string, std::string> matched_writer_user_data(dds_entity_t reader) {
    dds_instance_handle_t writer = 0;
    if (dds_get_matched_publications(reader, &writer, 1) != 1) return {};
    dds_builtintopic_endpoint_t* w = dds_get_matched_publication_data(reader, writer);
    if (!w) return {};
    void* data = nullptr;
    size_t size = 0;
    std::string user_data;
    if (dds_qget_userdata(w->qos, &data, &size))
        user_data.assign(static_cast<const char*>(data), size);
    dds_free(data);
    const std::string type = w->type_name;
    dds_builtintopic_free_endpoint(w);
    return {type, user_data};
}

class DdsPublisherTest : public ::testing::Test {
protected:
    void SetUp() override {
        test::use_loopback_dds();
        config_.domain_id = test::unique_domain_id();
        config_.max_blocking_ms = 20.0;
        participant_ = dds_create_participant(static_cast<dds_domainid_t>(config_.domain_id),
                                              nullptr, nullptr);
        ASSERT_GT(participant_, 0) << dds_strretcode(participant_);
    }
    void TearDown() override {
        if (participant_ > 0) dds_delete(participant_);
    }
    DdsConfig config_;
    dds_entity_t participant_ = 0;
};

TEST(DdsNames, TopicsAndTypesFollowRos2Mapping) {
    EXPECT_EQ(ros_topic_name("lidarfuse", "points"), "rt/lidarfuse/points");
    EXPECT_EQ(ros_topic_name("site/a", "poses"), "rt/site/a/poses");
    EXPECT_EQ(ros_topic_name("", "points"), "rt/points");
    EXPECT_STREQ(sensor_msgs_msg_dds__PointCloud2__desc.m_typename,
                 "sensor_msgs::msg::dds_::PointCloud2_");
    EXPECT_STREQ(tf2_msgs_msg_dds__TFMessage__desc.m_typename, "tf2_msgs::msg::dds_::TFMessage_");
    EXPECT_STREQ(diagnostic_msgs_msg_dds__DiagnosticArray__desc.m_typename,
                 "diagnostic_msgs::msg::dds_::DiagnosticArray_");
    EXPECT_STREQ(lidarfuse_msgs_msg_dds__FramePoses__desc.m_typename,
                 "lidarfuse_msgs::msg::dds_::FramePoses_");
}

TEST(DdsNames, DomainFromConfigElseRosDomainIdElseZero) {
    EXPECT_EQ(resolve_domain_id(7, "3"), 7);
    EXPECT_EQ(resolve_domain_id(-1, "3"), 3);
    EXPECT_EQ(resolve_domain_id(-1, nullptr), 0);
    EXPECT_EQ(resolve_domain_id(-1, ""), 0);
    EXPECT_THROW(resolve_domain_id(-1, "abc"), std::runtime_error);
    EXPECT_THROW(resolve_domain_id(-1, "233"), std::runtime_error);
}

TEST(DdsNames, RosTimeSplitsNanoseconds) {
    const auto t = to_ros_time(1'763'700'000'123'456'789LL);
    EXPECT_EQ(t.sec, 1'763'700'000);
    EXPECT_EQ(t.nanosec, 123'456'789u);
    EXPECT_EQ(from_ros_time(t), 1'763'700'000'123'456'789LL);
    const auto negative = to_ros_time(-1);
    EXPECT_EQ(negative.sec, -1);
    EXPECT_EQ(negative.nanosec, 999'999'999u);
}

TEST_F(DdsPublisherTest, MessagesRoundTripWithRosQos) {
    DdsPublisher publisher(config_, frames3());
    DdsReader<sensor_msgs_msg_dds__PointCloud2_> points(participant_,
                                                        &sensor_msgs_msg_dds__PointCloud2__desc,
                                                        "rt/lidarfuse/points", test::reader_qos(4));
    DdsReader<tf2_msgs_msg_dds__TFMessage_> tf(participant_, &tf2_msgs_msg_dds__TFMessage__desc,
                                               "rt/tf", test::reader_qos(4));
    DdsReader<lidarfuse_msgs_msg_dds__FramePoses_> poses(participant_,
                                                         &lidarfuse_msgs_msg_dds__FramePoses__desc,
                                                         "rt/lidarfuse/poses", test::reader_qos(4));
    ASSERT_TRUE(points.wait_matched() && tf.wait_matched() && poses.wait_matched());

    // The writer's QoS as the reader discovered it: what a ROS 2 subscriber sees.
    dds_instance_handle_t writers[4];
    ASSERT_EQ(dds_get_matched_publications(points.reader(), writers, 4), 1);
    dds_builtintopic_endpoint_t* w = dds_get_matched_publication_data(points.reader(), writers[0]);
    ASSERT_NE(w, nullptr);
    EXPECT_STREQ(w->topic_name, "rt/lidarfuse/points");
    EXPECT_STREQ(w->type_name, "sensor_msgs::msg::dds_::PointCloud2_");
    dds_reliability_kind_t reliability{};
    dds_duration_t max_blocking = 0;
    ASSERT_TRUE(dds_qget_reliability(w->qos, &reliability, &max_blocking));
    EXPECT_EQ(reliability, DDS_RELIABILITY_RELIABLE);
    EXPECT_EQ(max_blocking, DDS_MSECS(20));
    dds_history_kind_t history{};
    int32_t depth = 0;
    ASSERT_TRUE(dds_qget_history(w->qos, &history, &depth));
    EXPECT_EQ(history, DDS_HISTORY_KEEP_LAST);
    EXPECT_EQ(depth, config_.depth);
    dds_durability_kind_t durability{};
    ASSERT_TRUE(dds_qget_durability(w->qos, &durability));
    EXPECT_EQ(durability, DDS_DURABILITY_VOLATILE);
    uint32_t n_repr = 0;
    dds_data_representation_id_t* repr = nullptr;
    ASSERT_TRUE(dds_qget_data_representation(w->qos, &n_repr, &repr));
    ASSERT_EQ(n_repr, 1u);
    EXPECT_EQ(repr[0], DDS_DATA_REPRESENTATION_XCDR1);
    dds_free(repr);
    // USER_DATA as rmw_cyclonedds_cpp writes it: what ROS 2 Jazzy parses for the type hash.
    void* user_data = nullptr;
    size_t user_data_size = 0;
    ASSERT_TRUE(dds_qget_userdata(w->qos, &user_data, &user_data_size));
    EXPECT_EQ(std::string(static_cast<const char*>(user_data), user_data_size),
              "typehash=RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5;");
    EXPECT_EQ(user_data_size, 81u);
    dds_free(user_data);
    dds_builtintopic_free_endpoint(w);

    // Every writer announces its own type's hash.
    for (const dds_entity_t reader : {tf.reader(), poses.reader()}) {
        const auto [type, announced] = matched_writer_user_data(reader);
        EXPECT_EQ(announced, ros_type_hash_user_data(type)) << type;
    }
    EXPECT_EQ(matched_writer_user_data(poses.reader()).second,
              "typehash=" + ros_type_hash("lidarfuse_msgs/msg/FramePoses") + ";");

    const auto f = frame(5, 1000);
    publisher.publish_frame(f, sensor_stamps(f));

    int clouds = 0;
    ASSERT_TRUE(test::eventually([&] {
        clouds += points.take([&](const sensor_msgs_msg_dds__PointCloud2_& m) {
            EXPECT_STREQ(m.header.frame_id, "station");
            EXPECT_EQ(from_ros_time(m.header.stamp), f.t_ns[0]);  // the root's scan
            EXPECT_EQ(m.height, 1u);
            ASSERT_EQ(m.width, 1000u);
            EXPECT_EQ(m.point_step, kPointStep);
            EXPECT_EQ(m.row_step, 1000u * kPointStep);
            EXPECT_FALSE(m.is_bigendian);
            ASSERT_EQ(m.fields._length, 6u);
            const char* names[6] = {"x", "y", "z", "intensity", "sensor_id", "dynamic"};
            const std::uint32_t offsets[6] = {0, 4, 8, 12, 16, 17};
            const std::uint8_t types[6] = {7, 7, 7, 7, 2, 2};  // FLOAT32, UINT8
            for (int i = 0; i < 6; ++i) {
                EXPECT_STREQ(m.fields._buffer[i].name, names[i]);
                EXPECT_EQ(m.fields._buffer[i].offset, offsets[i]);
                EXPECT_EQ(m.fields._buffer[i].datatype, types[i]);
                EXPECT_EQ(m.fields._buffer[i].count, 1u);
            }
            ASSERT_EQ(m.data._length, 1000u * kPointStep);
            for (std::size_t i = 0; i < 1000; ++i) {
                const CloudPoint p = point_at(m, i);
                ASSERT_EQ(p.xyz[0], f.cloud.points[i].x());
                ASSERT_EQ(p.xyz[1], f.cloud.points[i].y());
                ASSERT_EQ(p.xyz[2], f.cloud.points[i].z());
                ASSERT_EQ(p.intensity, f.cloud.intensity[i]);
                ASSERT_EQ(p.sensor, f.cloud.sensor[i]);
                ASSERT_EQ(p.dynamic, f.cloud.dynamic[i]);
            }
        });
        return clouds >= 1;
    }));
    EXPECT_EQ(clouds, 1);

    int tfs = 0;
    ASSERT_TRUE(test::eventually([&] {
        tfs += tf.take([&](const tf2_msgs_msg_dds__TFMessage_& m) {
            // The root included; "south" has no scan in this frame, so it is left out.
            ASSERT_EQ(m.transforms._length, 2u);
            for (std::size_t s = 0; s < 2; ++s) {
                const auto& t = m.transforms._buffer[s];
                EXPECT_STREQ(t.header.frame_id, "station");
                EXPECT_STREQ(t.child_frame_id, frames3().sensor_names[s].c_str());
                EXPECT_EQ(from_ros_time(t.header.stamp), f.t_ns[s]);
                EXPECT_TRUE(from_ros_transform(t.transform).isApprox(f.T_root_sensor[s], 1e-12));
            }
        });
        return tfs >= 1;
    }));

    int pose_messages = 0;
    ASSERT_TRUE(test::eventually([&] {
        pose_messages += poses.take([&](const lidarfuse_msgs_msg_dds__FramePoses_& m) {
            EXPECT_EQ(m.frame_index, 5);
            EXPECT_STREQ(m.root_sensor, "north");
            EXPECT_STREQ(m.header.frame_id, "station");
            ASSERT_EQ(m.sensors._length, 3u);
            EXPECT_TRUE(m.sensors._buffer[1].included);
            EXPECT_FALSE(m.sensors._buffer[2].included);
            EXPECT_STREQ(m.sensors._buffer[2].track_state, "missing");
            EXPECT_EQ(from_ros_time(m.header.stamp), f.t_ns[0]);  // the earliest scan
            EXPECT_EQ(from_ros_time(m.sensors._buffer[1].stamp), f.t_ns[1]);
            EXPECT_EQ(from_ros_time(m.sensors._buffer[2].stamp), f.t_ns[0]);  // not in the frame
            EXPECT_DOUBLE_EQ(m.sensors._buffer[1].fitness, 0.75);
            EXPECT_TRUE(from_ros_transform(m.sensors._buffer[2].transform)
                            .isApprox(f.T_root_sensor[2], 1e-12));
        });
        return pose_messages >= 1;
    }));
    const auto c = publisher.counters();
    EXPECT_EQ(c.clouds, 1u);
    EXPECT_EQ(c.tf, 1u);
    EXPECT_EQ(c.poses, 1u);
    EXPECT_EQ(c.failures, 0u);
}

TEST(FrameMessageBuilder, FusedFrameNamedAsASensorIsRefused) {
    auto names = frames3();
    names.fused_frame = "north";  // tf2 would see north as its own parent
    EXPECT_THROW(FrameMessageBuilder builder(names), std::invalid_argument);
}

// Every stamp on rt/tf is a scan's: a sensor without a scan in the frame, or without a
// registered pose, is left out, never sent with stamp 0.
TEST(FrameMessageBuilder, TfHoldsOnlyRegisteredSensorsWithAScanInTheFrame) {
    FrameMessageBuilder builder(frames3());
    auto f = frame(0, 0);
    f.health[1].pose_valid = false;
    const auto& m = builder.tf(f, sensor_stamps(f));
    ASSERT_EQ(m.transforms._length, 1u);  // east unregistered, south not in the frame
    EXPECT_STREQ(m.transforms._buffer[0].child_frame_id, "north");
    EXPECT_STREQ(m.transforms._buffer[0].header.frame_id, "station");
    EXPECT_EQ(from_ros_time(m.transforms._buffer[0].header.stamp), f.t_ns[0]);
    f.health[0].included = false;
    EXPECT_EQ(builder.tf(f, sensor_stamps(f)).transforms._length, 0u);
}

TEST_F(DdsPublisherTest, NoEmptyTfAndNothingWithoutAStamp) {
    DdsPublisher publisher(config_, frames3());
    auto f = frame(0, 10);
    f.health[0].pose_valid = f.health[1].pose_valid = false;  // only south is registered...
    publisher.publish_frame(f, sensor_stamps(f));             // ... and has no scan here
    auto c = publisher.counters();
    EXPECT_EQ(c.tf, 0u);
    EXPECT_EQ(c.clouds, 1u);
    EXPECT_EQ(c.poses, 1u);
    for (auto& h : f.health) h.included = false;  // no scan at all: no stamp for anything
    publisher.publish_frame(f, sensor_stamps(f));
    c = publisher.counters();
    EXPECT_EQ(c.unstamped_frames, 1u);
    EXPECT_EQ(c.clouds, 1u);
    EXPECT_EQ(c.poses, 1u);
}

// A reliable reader whose history is full and which never takes cannot accept more; the
// writer waits at most max_blocking_time per write, then counts a timeout and goes on.
TEST_F(DdsPublisherTest, StalledReaderCostsCountedTimeoutsNotAStall) {
    config_.max_blocking_ms = 2.0;
    DdsPublisher publisher(config_, frames3());
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
    dds_qset_resource_limits(qos, 2, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
    DdsReader<lidarfuse_msgs_msg_dds__FramePoses_> stalled(
        participant_, &lidarfuse_msgs_msg_dds__FramePoses__desc, "rt/lidarfuse/poses", qos);
    ASSERT_TRUE(stalled.wait_matched());
    constexpr int kFrames = 12;
    for (int i = 0; i < kFrames; ++i) {
        const auto f = frame(i, 100);
        publisher.publish_frame(f, sensor_stamps(f));
    }
    auto c = publisher.counters();
    // Every poses write either went through (the first two fill the reader) or timed out.
    EXPECT_EQ(c.poses, 2u);
    EXPECT_EQ(c.timeouts, static_cast<std::uint64_t>(kFrames - 2));
    EXPECT_EQ(c.failures, c.timeouts);
    // The other topics, with no stalled reader, were not held up.
    EXPECT_EQ(c.clouds, static_cast<std::uint64_t>(kFrames));
    EXPECT_EQ(c.tf, static_cast<std::uint64_t>(kFrames));
    // Once the reader takes again, writes go through again.
    EXPECT_EQ(stalled.take([](const lidarfuse_msgs_msg_dds__FramePoses_&) {}), 2);
    const auto last = frame(kFrames, 100);
    publisher.publish_frame(last, sensor_stamps(last));
    c = publisher.counters();
    EXPECT_EQ(c.poses, 3u);
    EXPECT_EQ(c.timeouts, static_cast<std::uint64_t>(kFrames - 2));
}

TEST_F(DdsPublisherTest, DiagnosticsCarryStateLevelsAndCounters) {
    DdsPublisher publisher(config_, frames3());
    DdsReader<diagnostic_msgs_msg_dds__DiagnosticArray_> diag(
        participant_, &diagnostic_msgs_msg_dds__DiagnosticArray__desc, "rt/diagnostics",
        test::reader_qos(4));
    ASSERT_TRUE(diag.wait_matched());
    PipelineStats stats;
    stats.frames_fused = 10;
    const SensorState states[3] = {SensorState::kOk, SensorState::kStale, SensorState::kLost};
    for (int i = 0; i < 3; ++i) {
        SensorStats s;
        s.name = frames3().sensor_names[static_cast<std::size_t>(i)];
        s.state = states[i];
        s.packets = 1000u + static_cast<unsigned>(i);
        s.pose_valid = true;
        s.track_state = "tracking";
        stats.sensors.push_back(s);
    }
    stats.kernel_drops = 3;
    publisher.publish_diagnostics(stats, 1'763'700'000'500'000'000LL);
    int received = 0;
    ASSERT_TRUE(test::eventually([&] {
        received += diag.take([&](const diagnostic_msgs_msg_dds__DiagnosticArray_& m) {
            ASSERT_EQ(m.status._length, 4u);
            EXPECT_EQ(from_ros_time(m.header.stamp), 1'763'700'000'500'000'000LL);
            const std::uint8_t levels[3] = {0, 1, 2};  // OK, WARN, ERROR
            const char* messages[3] = {"OK", "STALE", "LOST"};
            for (std::size_t s = 0; s < 3; ++s) {
                const auto& st = m.status._buffer[s];
                EXPECT_EQ(st.level, levels[s]);
                EXPECT_STREQ(st.message, messages[s]);
                EXPECT_EQ(std::string(st.name), "lidarfuse/test/" + frames3().sensor_names[s]);
                std::map<std::string, std::string> values;
                for (std::uint32_t k = 0; k < st.values._length; ++k) {
                    values[st.values._buffer[k].key] = st.values._buffer[k].value;
                }
                EXPECT_EQ(values["packets"], std::to_string(1000 + s));
                EXPECT_EQ(values["state"], messages[s]);
                EXPECT_EQ(values["track_state"], "tracking");
                EXPECT_TRUE(values.count("completeness") && values.count("clock_offset_ms"));
            }
            const auto& pipeline = m.status._buffer[3];
            EXPECT_STREQ(pipeline.name, "lidarfuse/test/pipeline");
            EXPECT_EQ(pipeline.level, 1);  // kernel drops: WARN
        });
        return received >= 1;
    }));
}

}  // namespace
}  // namespace lidarfuse::daemon

namespace lidarfuse::daemon {
namespace {

// A cloud whose points fall 4 to a voxel of 1 m: (i / 4) m along x, static and dynamic apart.
core::FrameOutput frame_in_voxels(std::int64_t index, std::size_t points) {
    core::FrameOutput f = frame(index, 0);
    for (std::size_t i = 0; i < points; ++i) {
        const float x = static_cast<float>(i / 4) + 0.125f + 0.25f * static_cast<float>(i % 4);
        f.cloud.points.emplace_back(x, 0.5f, 0.5f);
        f.cloud.intensity.push_back(static_cast<float>(i % 4));
        f.cloud.sensor.push_back(static_cast<std::uint8_t>(i % 3));
        f.cloud.dynamic.push_back(static_cast<std::uint8_t>((i / 4) % 5 == 0));
    }
    return f;
}

TEST_F(DdsPublisherTest, TheThinnedCloudGoesOutOnlyWhenConfiguredAndWanted) {
    const auto f = frame_in_voxels(3, 400);
    {
        DdsPublisher off(config_, frames3());  // points_voxel_size_m 0: no such writer
        off.publish_frame(f, sensor_stamps(f));
        EXPECT_EQ(off.counters().voxel_clouds, 0u);
        EXPECT_TRUE(off.last_voxel_cloud().points.empty());
    }
    config_.points_voxel_size_m = 1.0;
    DdsPublisher publisher(config_, frames3());
    publisher.publish_frame(f, sensor_stamps(f));  // no reader yet: not even thinned
    EXPECT_EQ(publisher.counters().voxel_clouds, 0u);
    EXPECT_TRUE(publisher.last_voxel_cloud().points.empty());

    DdsReader<sensor_msgs_msg_dds__PointCloud2_> voxels(
        participant_, &sensor_msgs_msg_dds__PointCloud2__desc, "rt/lidarfuse/points_voxel",
        test::reader_qos(4));
    ASSERT_TRUE(voxels.wait_matched());
    publisher.publish_frame(f, sensor_stamps(f));
    EXPECT_EQ(publisher.counters().voxel_clouds, 1u);
    EXPECT_EQ(publisher.counters().clouds, 2u);  // the full cloud every time
    int received = 0;
    ASSERT_TRUE(test::eventually([&] {
        received += voxels.take([&](const sensor_msgs_msg_dds__PointCloud2_& m) {
            EXPECT_STREQ(m.header.frame_id, "station");
            EXPECT_EQ(from_ros_time(m.header.stamp), f.t_ns[0]);
            ASSERT_EQ(m.width, 100u);  // 400 points, 4 per voxel
            ASSERT_EQ(m.fields._length, 6u);
            ASSERT_EQ(m.data._length, 100u * kPointStep);
            for (std::size_t v = 0; v < 100; ++v) {
                const CloudPoint p = point_at(m, v);
                EXPECT_FLOAT_EQ(p.xyz[0], static_cast<float>(v) + 0.5f);  // the centroid
                EXPECT_FLOAT_EQ(p.xyz[1], 0.5f);
                EXPECT_FLOAT_EQ(p.intensity, 1.5f);                           // the mean
                EXPECT_EQ(p.sensor, static_cast<std::uint8_t>((4 * v) % 3));  // the first point's
                EXPECT_EQ(p.dynamic, v % 5 == 0 ? 1 : 0);
            }
        });
        return received >= 1;
    }));
    EXPECT_EQ(received, 1);
    EXPECT_EQ(publisher.last_voxel_cloud().points.size(), 100u);
}

}  // namespace
}  // namespace lidarfuse::daemon
