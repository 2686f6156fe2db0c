// Row "sensor clock jumps forward/backward (PTP lock, reboot, 37 s TAI offset)":
// detected, re-anchored, counted; never an unsigned underflow (or signed overflow); no
// frame back in time; the other sensors keep being grouped together.
// The synchroniser is driven the way the daemon's sync thread drives it: sensor
// timestamps decide membership, a monotonic `now` the deadlines.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <vector>

#include "core/pipeline/frame_synchroniser.hpp"

namespace lidarfuse::reliability {
namespace {

constexpr std::int64_t kPeriodNs = 50'000'000;  // 20 Hz
constexpr std::int64_t kTaiOffsetNs = 37'000'000'000;

struct SyncRun {
    std::vector<core::SyncedFrame<int>> frames;
    core::SyncCounters counters;
};

// Three sensors at 20 Hz for `scans` periods; sensor 2's clock is shifted by
// `offset_ns(i)` at scan i. The monotonic clock advances one period per scan.
template <typename OffsetFn>
SyncRun run(int scans, OffsetFn offset_ns) {
    core::SyncParams params;
    params.max_offset_ns = kPeriodNs;
    params.deadline_ns = 60'000'000;
    params.reset_jump_ns = 2'000'000'000;
    core::FrameSynchroniser<int> sync(3, params);
    SyncRun out;
    const std::int64_t t0 = 1'700'000'000'000'000'000;  // a PTP-like epoch time
    for (int i = 0; i < scans; ++i) {
        const std::int64_t now = 1'000'000'000 + i * kPeriodNs;
        const std::int64_t t = t0 + i * kPeriodNs;
        sync.push(0, t, now, i);
        sync.push(1, t + 1'000'000, now, i);
        sync.push(2, t + 2'000'000 + offset_ns(i), now, i);
        while (auto f = sync.poll(now + kPeriodNs / 2)) out.frames.push_back(std::move(*f));
    }
    for (int k = 0; k < 10; ++k) {
        while (auto f = sync.poll(1'000'000'000 + (scans + k) * kPeriodNs))
            out.frames.push_back(std::move(*f));
    }
    out.counters = sync.counters();
    return out;
}

void expect_healthy_pair_kept_fusing(const SyncRun& r, int scans) {
    std::size_t with_both = 0;
    for (const auto& f : r.frames)
        with_both += f.members[0].has_value() && f.members[1].has_value();
    // Sensors 0 and 1 were never disturbed: (nearly) every one of their scans leaves
    // grouped with the other's.
    EXPECT_GE(with_both, static_cast<std::size_t>(scans) - 3);
}

void expect_never_backwards_without_reset(const SyncRun& r) {
    std::size_t backwards = 0;
    for (std::size_t i = 1; i < r.frames.size(); ++i)
        backwards += r.frames[i].t_ns < r.frames[i - 1].t_ns;
    EXPECT_LE(backwards, r.counters.resets);
}

TEST(ClockJump, ForwardTaiOffsetOnOneSensorDoesNotStallTheOthers) {
    const int scans = 120;
    const SyncRun r = run(scans, [](int i) -> std::int64_t { return i >= 40 ? kTaiOffsetNs : 0; });
    expect_healthy_pair_kept_fusing(r, scans);
    expect_never_backwards_without_reset(r);
}

TEST(ClockJump, BackwardJumpOnOneSensorDoesNotStallTheOthers) {
    const int scans = 120;
    const SyncRun r = run(scans, [](int i) -> std::int64_t { return i >= 40 ? -kTaiOffsetNs : 0; });
    expect_healthy_pair_kept_fusing(r, scans);
    expect_never_backwards_without_reset(r);
}

TEST(ClockJump, ExtremeTimestampsNeverOverflow) {
    // Sensor 2 reports timestamps from a corrupted clock at both ends of the range (the
    // daemon casts u64 sensor nanoseconds to i64). Under UBSan an overflow aborts.
    const SyncRun r = run(40, [](int i) {
        if (i % 3 == 0) return std::numeric_limits<std::int64_t>::max() / 2;
        if (i % 3 == 1) return std::numeric_limits<std::int64_t>::min() / 2;
        return std::int64_t{0};
    });
    EXPECT_GT(r.frames.size(), 0u);
    expect_never_backwards_without_reset(r);
}

}  // namespace
}  // namespace lidarfuse::reliability
