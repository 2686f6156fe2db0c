// PointCloud2Source (daemon/point_cloud2_source.hpp) against a real Cyclone DDS writer on
// loopback: the daemon's own cloud messages arrive as their points and stamps, a cloud
// whose layout cannot be read is counted with the reason naming the source and the field,
// non-finite points are counted, and nothing is handed on after stop().
#include "daemon/point_cloud2_source.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

#include "daemon/dds_messages.hpp"
#include "tests/daemon/dds_test_support.hpp"

namespace lidarfuse::daemon {
namespace {

struct Got {
    std::int64_t stamp_ns;
    std::string frame_id;
    std::vector<Eigen::Vector3d> points;
};

core::FusedCloud cloud_of(int frame) {
    core::FusedCloud c;
    for (int i = 0; i < 50; ++i) {
        c.points.emplace_back(0.5f * i, static_cast<float>(frame), -1.0f);
        c.intensity.push_back(1.0f);
        c.sensor.push_back(0);
        c.dynamic.push_back(0);
    }
    return c;
}

class PointCloud2SourceTest : public ::testing::Test {
protected:
    void SetUp() override {
        test::use_loopback_dds();
        domain_ = test::unique_domain_id();
        participant_ =
            dds_create_participant(static_cast<dds_domainid_t>(domain_), nullptr, nullptr);
        ASSERT_GT(participant_, 0);
        const dds_entity_t topic = dds_create_topic(
            participant_, &sensor_msgs_msg_dds__PointCloud2__desc, kTopic, nullptr, nullptr);
        ASSERT_GT(topic, 0);
        dds_qos_t* qos = test::reader_qos(16);
        writer_ = dds_create_writer(participant_, topic, qos, nullptr);
        dds_delete_qos(qos);
        ASSERT_GT(writer_, 0);
    }
    void TearDown() override { dds_delete(participant_); }

    std::unique_ptr<PointCloud2Source> started_source() {
        auto source = std::make_unique<PointCloud2Source>(
            PointCloud2SourceConfig{"station1", kTopic, domain_, 16},
            [this](const ReceivedCloud& c) {
                const std::lock_guard<std::mutex> lock(mutex_);
                got_.push_back({c.stamp_ns, c.frame_id, c.points->points});
            });
        source->start();
        EXPECT_TRUE(test::eventually([&] { return source->publishers() > 0; }));
        return source;
    }
    std::size_t got() {
        const std::lock_guard<std::mutex> lock(mutex_);
        return got_.size();
    }

    static constexpr const char* kTopic = "rt/station1/points";
    int domain_ = 0;
    dds_entity_t participant_ = 0;
    dds_entity_t writer_ = 0;
    FrameMessageBuilder builder_{{"station1", "road", {"lidar0"}, 0}};
    std::mutex mutex_;
    std::vector<Got> got_;
};

TEST_F(PointCloud2SourceTest, CloudsArriveAsTheirPointsAndStampsAndBadOnesAreCounted) {
    auto source = started_source();
    FrameStamps stamps;
    for (int f = 0; f < 5; ++f) {
        stamps.frame_ns = 1'763'700'000'000'000'000 + f * 50'000'000LL;
        ASSERT_EQ(dds_write(writer_, &builder_.cloud(cloud_of(f), stamps)), DDS_RETCODE_OK);
    }
    // Without its z field: refused, and counted with the reason.
    sensor_msgs_msg_dds__PointCloud2_ broken = builder_.cloud(cloud_of(9), stamps);
    broken.fields._length = 2;
    ASSERT_EQ(dds_write(writer_, &broken), DDS_RETCODE_OK);
    // Two points without a return (NaN), as ROS drivers mark them.
    core::FusedCloud holes = cloud_of(6);
    holes.points[3].x() = std::numeric_limits<float>::quiet_NaN();
    holes.points[7].z() = std::numeric_limits<float>::quiet_NaN();
    stamps.frame_ns += 50'000'000;
    ASSERT_EQ(dds_write(writer_, &builder_.cloud(holes, stamps)), DDS_RETCODE_OK);

    ASSERT_TRUE(test::eventually([&] { return source->counters().clouds == 6; }));
    ASSERT_TRUE(test::eventually([&] { return source->counters().refused == 1; }));
    const auto counters = source->counters();
    EXPECT_EQ(counters.non_finite_points, 2u);
    EXPECT_NE(counters.last_error.find("station1"), std::string::npos) << counters.last_error;
    EXPECT_NE(counters.last_error.find("field 'z': missing"), std::string::npos)
        << counters.last_error;
    const std::lock_guard<std::mutex> lock(mutex_);
    ASSERT_EQ(got_.size(), 6u);
    for (int f = 0; f < 5; ++f) {
        const auto& g = got_[static_cast<std::size_t>(f)];
        EXPECT_EQ(g.stamp_ns, 1'763'700'000'000'000'000 + f * 50'000'000LL);
        EXPECT_EQ(g.frame_id, "road");
        const auto expected = cloud_of(f);
        ASSERT_EQ(g.points.size(), expected.points.size());
        for (std::size_t i = 0; i < g.points.size(); ++i)
            EXPECT_EQ(g.points[i], expected.points[i].cast<double>());
    }
    EXPECT_EQ(got_.back().points.size(), 48u);
}

TEST_F(PointCloud2SourceTest, NothingIsHandedOnAfterStop) {
    auto source = started_source();
    FrameStamps stamps;
    stamps.frame_ns = 1'763'700'000'000'000'000;
    ASSERT_EQ(dds_write(writer_, &builder_.cloud(cloud_of(0), stamps)), DDS_RETCODE_OK);
    ASSERT_TRUE(test::eventually([&] { return got() == 1; }));
    source->stop();
    ASSERT_EQ(dds_write(writer_, &builder_.cloud(cloud_of(1), stamps)), DDS_RETCODE_OK);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_EQ(got(), 1u);
    EXPECT_EQ(source->counters().clouds, 1u);
}

TEST(PointCloud2Source, ATopicNameDdsRefusesIsAnErrorNamingTheSource) {
    test::use_loopback_dds();
    try {
        PointCloud2Source source({"station2", "rt/bad topic?*", test::unique_domain_id(), 4},
                                 [](const ReceivedCloud&) {});
        FAIL() << "created";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("station2"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("rt/bad topic?*"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace lidarfuse::daemon
