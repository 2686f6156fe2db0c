#include "core/pipeline/frame_input.hpp"

#include <gtest/gtest.h>

namespace lidarfuse::core {
namespace {

struct TestScan {
    std::int64_t t_ns = 0;
    std::vector<Eigen::Vector3f> points;
    std::vector<float> point_dt_s;
    std::vector<float> intensity;
};

TEST(FrameInput, MembersAreMovedIntoTheirSensorsSlotsAndAbsentOnesStayAbsent) {
    SyncedFrame<TestScan> frame;
    frame.members.resize(3);
    frame.members[0] = TestScan{100, {Eigen::Vector3f(1, 2, 3)}, {0.01f}, {7.0f}};
    frame.members[2] = TestScan{120, {Eigen::Vector3f(4, 5, 6), Eigen::Vector3f(7, 8, 9)}, {}, {}};

    const FrameInput input = frame_input(&frame, 3);
    ASSERT_EQ(input.sensors.size(), 3u);
    EXPECT_TRUE(input.sensors[0].present);
    EXPECT_EQ(input.sensors[0].t_ns, 100);
    ASSERT_EQ(input.sensors[0].points.size(), 1u);
    EXPECT_EQ(input.sensors[0].points[0], Eigen::Vector3f(1, 2, 3));
    EXPECT_EQ(input.sensors[0].point_dt_s, std::vector<float>{0.01f});
    EXPECT_EQ(input.sensors[0].intensity, std::vector<float>{7.0f});
    EXPECT_FALSE(input.sensors[1].present);
    EXPECT_TRUE(input.sensors[1].points.empty());
    EXPECT_TRUE(input.sensors[2].present);
    EXPECT_EQ(input.sensors[2].t_ns, 120);
    EXPECT_EQ(input.sensors[2].points.size(), 2u);
    EXPECT_TRUE(input.sensors[2].point_dt_s.empty());
    // Moved, not copied; the frame still says which sensors it included.
    EXPECT_TRUE(frame.members[0]->points.empty());
    EXPECT_EQ(frame.included(), 2u);
}

TEST(FrameInput, MoreSensorsThanMembersLeavesTheRestAbsent) {
    SyncedFrame<TestScan> frame;
    frame.members.resize(1);
    frame.members[0] = TestScan{5, {Eigen::Vector3f::Zero()}, {}, {}};
    const FrameInput input = frame_input(&frame, 2);
    ASSERT_EQ(input.sensors.size(), 2u);
    EXPECT_TRUE(input.sensors[0].present);
    EXPECT_FALSE(input.sensors[1].present);
}

}  // namespace
}  // namespace lidarfuse::core
