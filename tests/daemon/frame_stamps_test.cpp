// The stamps of a fused frame's messages: the sensors' or the host's clock, the frame's
// stamp the earliest of its scans', and nothing stamped for a sensor without a scan.
#include "daemon/frame_stamps.hpp"

#include <gtest/gtest.h>

namespace lidarfuse::daemon {
namespace {

core::FrameOutput frame_of(const std::vector<std::int64_t>& t_ns,
                           const std::vector<bool>& included) {
    core::FrameOutput f;
    f.t_ns = t_ns;
    f.health.resize(t_ns.size());
    for (std::size_t s = 0; s < t_ns.size(); ++s) {
        f.health[s].included = included[s];
        f.health[s].pose_valid = true;
    }
    return f;
}

TEST(FrameStamps, SensorClockTheFrameIsItsEarliestScan) {
    const auto f = frame_of({1'000'300, 1'000'100, 1'000'000}, {true, true, false});
    const FrameStamps st = frame_stamps(f, StampSource::kSensor, {});
    EXPECT_EQ(st.sensor_ns, (std::vector<std::int64_t>{1'000'300, 1'000'100, 0}));
    EXPECT_EQ(st.frame_ns, 1'000'100);  // sensor 2's earlier time is not in the frame
}

TEST(FrameStamps, HostClockTakesEachScansReceiveTime) {
    const auto f = frame_of({5, 6, 7}, {true, true, true});
    const FrameStamps st = frame_stamps(f, StampSource::kHost,
                                        {1'763'700'000'020'000'000, 1'763'700'000'010'000'000, 0});
    EXPECT_EQ(st.sensor_ns,
              (std::vector<std::int64_t>{1'763'700'000'020'000'000, 1'763'700'000'010'000'000, 0}));
    EXPECT_EQ(st.frame_ns, 1'763'700'000'010'000'000);
}

// The cloud holds the registered sensors only, and only they are on tf: an unregistered
// sensor's earlier scan would put the stamp before every registered sensor's sample.
TEST(FrameStamps, TheFrameIsItsEarliestRegisteredScan) {
    auto f = frame_of({300, 100, 200}, {true, true, true});
    f.health[1].pose_valid = false;
    EXPECT_EQ(frame_stamps(f, StampSource::kSensor, {}).frame_ns, 200);
    for (auto& h : f.health) h.pose_valid = false;  // none registered yet: all of them
    EXPECT_EQ(frame_stamps(f, StampSource::kSensor, {}).frame_ns, 100);
}

TEST(FrameStamps, NoPositiveStampNoFrameStamp) {
    const auto f = frame_of({0, -5, 9}, {true, true, false});
    const FrameStamps st = frame_stamps(f, StampSource::kSensor, {});
    EXPECT_EQ(st.sensor_ns, (std::vector<std::int64_t>{0, 0, 0}));
    EXPECT_EQ(st.frame_ns, 0);
}

}  // namespace
}  // namespace lidarfuse::daemon
