// Row "host wall clock jumps": no effect (monotonic clocks for time-outs and latency).
//
// Changing the host's clock needs CAP_SYS_TIME, so the test runs itself again with an
// LD_PRELOAD shim (realtime_shift_shim.c, built next to this test) that shifts what this
// process reads from CLOCK_REALTIME, gettimeofday() and time() by an offset the test sets
// while lidarfused's Pipeline fuses a replayed station: +1 h, then -1 day. The replay
// (the sensors) runs without the shim. Asserted in each phase: frames keep being
// synchronised at (at least half) the 20 Hz rate and fused, no sensor goes LOST or
// MODE_MISMATCH and the age of its last scan stays in [0, lost_after_ms), the latency
// stays in [0, 1 s), the fusion heartbeat stays fresh. And that the shim took effect:
// system_clock, time(), gettimeofday() and the daemon's realtime_ns() jump with it,
// steady_clock does not, and the reported clock_offset_ms (sensor clock minus host wall
// clock) jumps by minus the offset.
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

#include "daemon/sensor_ingest.hpp"
#include "tests/reliability/station_fixture.hpp"

namespace lidarfuse::reliability {
namespace {

using namespace std::chrono_literals;
using SetShiftFn = void (*)(std::int64_t);
constexpr std::int64_t kHourNs = 3'600'000'000'000LL;
constexpr std::int64_t kDayNs = 24 * kHourNs;
constexpr const char* kChildVariable = "LIDARFUSE_REALTIME_SHIFT_CHILD";

SetShiftFn shim() {
    return reinterpret_cast<SetShiftFn>(::dlsym(RTLD_DEFAULT, "lidarfuse_realtime_shift_set_ns"));
}

// Wall-clock minus steady-clock time, ns, through each way a program reads the wall clock.
std::array<std::int64_t, 4> wall_minus_steady_ns() {
    const auto steady = daemon::steady_ns();
    const auto sys = std::chrono::duration_cast<std::chrono::nanoseconds>(
                         std::chrono::system_clock::now().time_since_epoch())
                         .count();
    timeval tv{};
    ::gettimeofday(&tv, nullptr);
    const std::int64_t tod =
        static_cast<std::int64_t>(tv.tv_sec) * 1'000'000'000 + tv.tv_usec * 1000;
    const std::int64_t t = static_cast<std::int64_t>(std::time(nullptr)) * 1'000'000'000;
    return {sys - steady, daemon::realtime_ns() - steady, tod - steady, t - steady};
}

// Runs this test in a child process with the shim preloaded; true when this process is
// that child (the shim is loaded).
bool in_child_or_run_child() {
    if (shim()) return true;
    if (std::getenv(kChildVariable)) {
        ADD_FAILURE() << "LD_PRELOAD did not load " << LIDARFUSE_REALTIME_SHIFT_SHIM;
        return false;
    }
    char self[4096] = {};
    const ssize_t n = ::readlink("/proc/self/exe", self, sizeof self - 1);
    EXPECT_GT(n, 0);
    if (n <= 0) return false;
    const char* asan = std::getenv("ASAN_OPTIONS");
    // The shim is preloaded ahead of ASan's runtime (in the sanitizer build), which ASan
    // refuses unless told that this order is intended.
    const std::string command =
        std::string("LD_PRELOAD=") + LIDARFUSE_REALTIME_SHIFT_SHIM + " " + kChildVariable +
        "=1 ASAN_OPTIONS=" + (asan ? std::string(asan) + ":" : std::string()) +
        "verify_asan_link_order=0 " + self + " --gtest_filter=" +
        ::testing::UnitTest::GetInstance()->current_test_info()->test_suite_name() + "." +
        ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::string output;
    const int status = test::run_command(command, &output);
    EXPECT_EQ(status, 0) << output;
    EXPECT_NE(output.find("[  PASSED  ] 1 test."), std::string::npos) << output;
    std::printf("%s", output.c_str());
    return false;
}

struct Sample {
    double at_s;
    daemon::PipelineStats stats;
    double heartbeat_age_s;
};

TEST(HostClockJump, WallClockJumpsChangeOnlyTheReportedClockOffset) {
    if (!in_child_or_run_child()) return;
    const SetShiftFn set_shift = shim();
    // The simulator and the replay stand for the sensors: they keep the true time.
    ::unsetenv("LD_PRELOAD");

    // The shim works for every way of reading the wall clock, and only for those.
    const auto before = wall_minus_steady_ns();
    set_shift(kHourNs);
    const auto shifted = wall_minus_steady_ns();
    set_shift(0);
    for (std::size_t i = 0; i < before.size(); ++i) {
        // time() has 1 s resolution; the others are exact to the calls' spacing.
        EXPECT_NEAR(static_cast<double>(shifted[i] - before[i]), static_cast<double>(kHourNs),
                    1.01e9)
            << i;
    }

    test::TempDir sim("clock-shift-sim"), out("clock-shift-out");
    simulate(sim.path(), 9.0, {});
    const int slot = 0;
    const auto config = station_config(sim.path(), out.path(), slot);
    daemon::Pipeline pipeline(config);
    pipeline.start();
    const auto start = std::chrono::steady_clock::now();
    const auto now_s = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    BackgroundReplay replay(sim.path() / "capture.pcap", "--to 127.0.0.1" + port_map(slot, 2));
    const auto all_ok = [&] {
        const auto st = pipeline.stats();
        return std::all_of(st.sensors.begin(), st.sensors.end(), [](const daemon::SensorStats& s) {
            return s.state == daemon::SensorState::kOk;
        });
    };
    ASSERT_TRUE(wait_for(all_ok, 5s));

    // Phases: 0 true time, 1 wall clock +1 h, 2 wall clock -1 day; 2 s each.
    const std::array<std::int64_t, 3> shifts = {0, kHourNs, -kDayNs};
    std::array<std::vector<Sample>, 3> phases;
    for (std::size_t p = 0; p < shifts.size(); ++p) {
        set_shift(shifts[p]);
        const double phase_end = now_s() + 2.0;
        while (now_s() < phase_end && !replay.done()) {
            phases[p].push_back({now_s(), pipeline.stats(),
                                 std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                                               pipeline.heartbeat())
                                     .count()});
            std::this_thread::sleep_for(20ms);
        }
    }
    const std::uint64_t reads_before_stop = reinterpret_cast<std::uint64_t (*)()>(
        ::dlsym(RTLD_DEFAULT, "lidarfuse_realtime_shift_reads"))();
    set_shift(0);
    ASSERT_EQ(replay.join(), 0) << replay.output();
    pipeline.stop();
    EXPECT_GT(reads_before_stop, 0u);

    std::array<double, 3> median_offset_ms{};
    for (std::size_t p = 0; p < phases.size(); ++p) {
        SCOPED_TRACE("phase " + std::to_string(p) + " (wall clock shifted " +
                     std::to_string(shifts[p] / 1'000'000'000) + " s)");
        const auto& samples = phases[p];
        ASSERT_GE(samples.size(), 20u) << "the replay ended too early";
        const auto& first = samples.front();
        const auto& last = samples.back();
        const double span_s = last.at_s - first.at_s;
        EXPECT_GE(
            static_cast<double>(last.stats.frames_synchronised - first.stats.frames_synchronised),
            0.5 * 20.0 * span_s);
        // Fusion keeps going (its rate is the CPU's, not the clocks': a few frames per
        // second under ASan on a loaded machine).
        EXPECT_GT(last.stats.frames_fused, first.stats.frames_fused);
        std::size_t stale = 0;
        std::vector<double> offsets;
        for (const auto& s : samples) {
            // A wall-clock age or latency would be 1 h or 1 day off. The bounds leave room for
            // a ThreadSanitizer build sharing the cores (seen: a frame taking 1.2 s).
            EXPECT_LT(s.heartbeat_age_s, 10.0);
            EXPECT_GE(s.stats.last_latency_ms, 0.0);
            EXPECT_LT(s.stats.last_latency_ms, 10000.0);
            for (const auto& sensor : s.stats.sensors) {
                EXPECT_NE(sensor.state, daemon::SensorState::kLost)
                    << sensor.name << " at " << s.at_s;
                EXPECT_NE(sensor.state, daemon::SensorState::kModeMismatch) << sensor.name;
                EXPECT_GE(sensor.ms_since_last_scan, 0.0) << sensor.name;
                EXPECT_LT(sensor.ms_since_last_scan, config.health.lost_after_ms) << sensor.name;
                stale += sensor.state == daemon::SensorState::kStale;
            }
            offsets.push_back(s.stats.sensors[0].clock_offset_ms);
        }
        // STALE (250 ms without a scan) only as often as a loaded machine delays a
        // receiver; a wall-clock age would be 1 h or 1 day off, every sample.
        EXPECT_LE(stale, samples.size() / 10) << "STALE samples";
        // The offset is measured when a scan completes: the median of the phase's second
        // half, well after the shift.
        std::vector<double> late(offsets.begin() + static_cast<std::ptrdiff_t>(offsets.size() / 2),
                                 offsets.end());
        std::nth_element(late.begin(), late.begin() + static_cast<std::ptrdiff_t>(late.size() / 2),
                         late.end());
        median_offset_ms[p] = late[late.size() / 2];
    }
    std::printf("host_clock_jump_clock_offset_ms %.1f %.1f %.1f ms (true, +1 h, -1 day)\n",
                median_offset_ms[0], median_offset_ms[1], median_offset_ms[2]);
    std::printf("host_clock_jump_shifted_reads %llu reads\n",
                static_cast<unsigned long long>(reads_before_stop));
    // The daemon read the shifted wall clock: sensor clock minus host clock jumped by
    // minus the shift (to within the scans' spacing and the replay's jitter).
    EXPECT_NEAR(median_offset_ms[1] - median_offset_ms[0], -3'600'000.0, 500.0);
    EXPECT_NEAR(median_offset_ms[2] - median_offset_ms[0], 86'400'000.0, 500.0);
}

}  // namespace
}  // namespace lidarfuse::reliability
