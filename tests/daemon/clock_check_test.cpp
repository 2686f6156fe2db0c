// Sensor clocks checked against the root's before synchronisation (daemon/clock_check.hpp).
#include "daemon/clock_check.hpp"

#include <gtest/gtest.h>

namespace lidarfuse::daemon {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kS = 1'000 * kMs;
// Sensor clock (PTP, TAI-like) and host steady clock, far apart as they are in the field.
constexpr std::int64_t kSensorT0 = 1'764'000'000 * kS;
constexpr std::int64_t kSteadyT0 = 3'600 * kS;

// Frame k of a 20 Hz station at steady time kSteadyT0 + k periods; `skew` on the sensor's
// clock and `latency` between its scan time and its completion on the host.
struct Scan {
    std::int64_t t_ns, steady_ns;
};
Scan scan(int k, std::int64_t skew = 0, std::int64_t latency = 50 * kMs) {
    return {kSensorT0 + k * 50 * kMs + skew, kSteadyT0 + k * 50 * kMs + latency};
}

TEST(ClockCheck, SynchronisedSensorsAreTakenWhateverTheirLatency) {
    ClockCheck check(3, 0, kS);
    for (int k = 0; k < 40; ++k) {
        EXPECT_FALSE(check.refuse(0, scan(k).t_ns, scan(k).steady_ns));
        // A station's fused cloud arrives after its fusion: 400 ms later than the root's scan.
        EXPECT_FALSE(check.refuse(1, scan(k, 0, 450 * kMs).t_ns, scan(k, 0, 450 * kMs).steady_ns));
        EXPECT_FALSE(check.refuse(2, scan(k, 3 * kMs).t_ns, scan(k, 3 * kMs).steady_ns));
    }
}

TEST(ClockCheck, AClockOffBySecondsIsRefusedFromItsFirstScanWithItsSkew) {
    ClockCheck check(3, 1, kS);  // the root is sensor 1
    // Before the root has sent anything there is nothing to compare with.
    EXPECT_FALSE(check.refuse(0, scan(0, 5 * kS).t_ns, scan(0).steady_ns));
    EXPECT_FALSE(check.refuse(1, scan(0).t_ns, scan(0).steady_ns));
    for (int k = 1; k < 60; ++k) {
        EXPECT_FALSE(check.refuse(1, scan(k).t_ns, scan(k).steady_ns));
        const auto ahead = check.refuse(0, scan(k, 5 * kS).t_ns, scan(k).steady_ns);
        ASSERT_TRUE(ahead) << k;
        EXPECT_EQ(*ahead, 5 * kS);
        const auto behind = check.refuse(2, scan(k, -1500 * kMs).t_ns, scan(k).steady_ns);
        ASSERT_TRUE(behind) << k;
        EXPECT_EQ(*behind, -1500 * kMs);
    }
    // Just inside the bound is taken.
    EXPECT_FALSE(check.refuse(2, scan(60, 999 * kMs).t_ns, scan(60).steady_ns));
}

// A looped replay (or a PTP step) moves every clock at once, one sensor after the other:
// whichever jumps first, only the other sensor's scan between the two jumps is refused.
TEST(ClockCheck, ClocksThatJumpTogetherCostOnlyTheScanBetweenTheJumps) {
    for (const bool root_first : {true, false}) {
        ClockCheck check(2, 0, kS);
        for (int k = 0; k < 10; ++k) {
            EXPECT_FALSE(check.refuse(0, scan(k).t_ns, scan(k).steady_ns));
            EXPECT_FALSE(check.refuse(1, scan(k).t_ns, scan(k).steady_ns));
        }
        // The capture restarts: sensor time 4 s back, one sensor a frame after the other.
        for (int k = 10; k < 20; ++k) {
            const std::int64_t root = k >= (root_first ? 10 : 11) ? -4 * kS : 0;
            const std::int64_t other = k >= (root_first ? 11 : 10) ? -4 * kS : 0;
            EXPECT_FALSE(check.refuse(0, scan(k, root).t_ns, scan(k).steady_ns)) << k;
            const auto skew = check.refuse(1, scan(k, other).t_ns, scan(k).steady_ns);
            EXPECT_EQ(skew.has_value(), k == 10)
                << k << (root_first ? ", root first" : ", other first");
            if (skew) {
                EXPECT_EQ(*skew, root_first ? 4 * kS : -4 * kS);
            }
        }
    }
}

// A sensor whose clock jumps alone (a 37 s TAI offset, its PTP lost) is refused from its
// first scan after the jump, and taken again when it agrees again.
TEST(ClockCheck, ASensorThatJumpsAloneIsRefusedAtOnceAndTakenBackWhenItAgrees) {
    ClockCheck check(2, 0, kS);
    for (int k = 0; k < 60; ++k) {
        EXPECT_FALSE(check.refuse(0, scan(k).t_ns, scan(k).steady_ns));
        const bool jumped = k >= 10 && k < 50;
        const auto skew = check.refuse(1, scan(k, jumped ? 37 * kS : 0).t_ns, scan(k).steady_ns);
        EXPECT_EQ(skew.has_value(), jumped) << k;
    }
}

TEST(ClockCheck, ABoundOfZeroChecksNothing) {
    ClockCheck check(2, 0, 0);
    EXPECT_FALSE(check.refuse(0, scan(0).t_ns, scan(0).steady_ns));
    EXPECT_FALSE(check.refuse(1, scan(0, 3'600 * kS).t_ns, scan(0).steady_ns));
    EXPECT_FALSE(check.refuse(5, scan(0).t_ns, scan(0).steady_ns));  // no such sensor
}

}  // namespace
}  // namespace lidarfuse::daemon
