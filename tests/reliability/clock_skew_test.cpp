// Row "a sensor's clock off by seconds from the root's": a simulated 2-sensor station whose
// lidar1 stamps its packets 37 s ahead (the TAI-UTC offset of a sensor on TAI beside one on
// UTC; the simulator's clock-offset fault), replayed in real time through loopback sockets.
// lidar1's scans are refused before synchronisation (daemon/clock_check.hpp), counted and
// reported CLOCK_SKEW with the skew; lidar0, the root, goes into a frame at every scan.
// (How many of those frames fusion takes depends on the machine's load.) Without the check
// (sync.max_clock_skew_ms: 0) the synchroniser made 120 frames of one sensor each out of 60
// scans of each, their times alternating 37 s apart (every backward jump a reset): fusion
// was handed frames going back and forth in time.
#include <gtest/gtest.h>

#include "daemon/status_line.hpp"
#include "tests/reliability/station_fixture.hpp"

namespace lidarfuse::reliability {
namespace {

using daemon::SensorState;
using namespace std::chrono_literals;

TEST(ClockSkew, ASensor37SecondsAheadIsRefusedAndReportedWhileTheRootIsSynchronisedAtEveryScan) {
    test::TempDir sim("skew-sim");
    simulate(sim.path(), 3.0, {"clock-offset:lidar1:37"});
    test::TempDir out("skew-out");
    daemon::Pipeline pipeline(station_config(sim.path(), out.path(), 0));
    pipeline.start();
    BackgroundReplay replay(sim.path() / "capture.pcap", "--to 127.0.0.1" + port_map(0, 2));
    // lidar1's state while it sends (once the replay ends, both go STALE, then LOST).
    std::size_t samples = 0, skewed = 0;
    std::string line;
    while (!replay.done()) {
        const daemon::PipelineStats now = pipeline.stats();
        if (now.sensors[1].scans > 2) {
            ++samples;
            if (now.sensors[1].state == SensorState::kClockSkew) {
                ++skewed;
                line = daemon::status_line(now);
            }
        }
        std::this_thread::sleep_for(20ms);
    }
    ASSERT_EQ(replay.join(), 0) << replay.output();
    // The last frames leave after their deadline.
    std::this_thread::sleep_for(200ms);
    const daemon::PipelineStats st = pipeline.stats();
    pipeline.stop();
    std::printf("clock skew: %s; %llu synchronised, %llu late\n", line.c_str(),
                static_cast<unsigned long long>(st.frames_synchronised),
                static_cast<unsigned long long>(st.scans_late));

    const auto& root = st.sensors[0];
    const auto& ahead = st.sensors[1];
    EXPECT_GE(root.scans, 50u);  // 3 s at 20 Hz, less what a loaded machine loses
    EXPECT_EQ(root.scans_off_clock, 0u);
    // A scan of lidar1 before lidar0's first has nothing to be compared with.
    EXPECT_GE(ahead.scans_off_clock + 1, ahead.scans);
    EXPECT_GE(ahead.scans_off_clock, 50u);
    EXPECT_GT(samples, 50u);
    EXPECT_EQ(skewed, samples);
    EXPECT_NEAR(ahead.clock_skew_ms, 37'000.0, 100.0);
    // The skew in the text is the value above (delivery jitter: 36.998-37.003 s seen).
    EXPECT_NE(line.find("1 CLOCK_SKEW: clock 3"), std::string::npos) << line;
    EXPECT_NE(line.find(" s ahead of the root's (lidar1)"), std::string::npos) << line;
    // lidar0 in a frame of its own at every scan, none of them late.
    EXPECT_LE(st.scans_late, 1u);
    EXPECT_GE(st.frames_synchronised + 2, root.scans);
    EXPECT_GT(st.frames_fused, 0u);
}

}  // namespace
}  // namespace lidarfuse::reliability
