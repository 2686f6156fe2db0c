#include "core/pipeline/frame_synchroniser.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace lidarfuse::core {
namespace {

constexpr std::int64_t kMs = 1'000'000;

SyncParams params() {
    SyncParams p;
    p.max_offset_ns = 50 * kMs;
    p.deadline_ns = 60 * kMs;
    p.reset_jump_ns = 2000 * kMs;
    return p;
}

TEST(FrameSynchroniser, CompleteFrameLeavesAtOnce) {
    FrameSynchroniser<int> sync(3, params());
    sync.push(0, 1000 * kMs, 0, 10);
    sync.push(2, 1003 * kMs, 1 * kMs, 12);
    EXPECT_FALSE(sync.poll(2 * kMs).has_value());
    sync.push(1, 1001 * kMs, 2 * kMs, 11);
    auto frame = sync.poll(2 * kMs);
    ASSERT_TRUE(frame.has_value());
    EXPECT_EQ(frame->t_ns, 1000 * kMs);
    EXPECT_EQ(frame->included(), 3u);
    EXPECT_EQ(*frame->members[1], 11);
    EXPECT_EQ(sync.counters().frames_complete, 1u);
    EXPECT_EQ(sync.open_frames(), 0u);
}

TEST(FrameSynchroniser, MissingSensorLeavesAfterTheDeadlineWithoutIt) {
    FrameSynchroniser<int> sync(3, params());
    sync.push(0, 1000 * kMs, 100 * kMs, 10);
    sync.push(1, 1002 * kMs, 101 * kMs, 11);
    EXPECT_FALSE(sync.poll(159 * kMs).has_value());  // deadline runs from the first member
    auto frame = sync.poll(160 * kMs);
    ASSERT_TRUE(frame.has_value());
    EXPECT_EQ(frame->included(), 2u);
    EXPECT_FALSE(frame->members[2].has_value());
    EXPECT_EQ(sync.counters().frames_partial, 1u);
}

// What the daemon's sync thread sleeps until when no scan arrives: the earliest deadline
// of the open frames, each counted from its first member.
TEST(FrameSynchroniser, NextDeadlineIsTheEarliestOpenFramesDeadline) {
    FrameSynchroniser<int> sync(2, params());
    EXPECT_FALSE(sync.next_deadline_ns().has_value());
    sync.push(0, 1000 * kMs, 100 * kMs, 10);
    sync.push(1, 1002 * kMs, 130 * kMs, 11);  // the same frame: its deadline stays
    EXPECT_EQ(sync.next_deadline_ns(), 160 * kMs);
    sync.push(0, 1100 * kMs, 140 * kMs, 12);  // a second frame, due later
    EXPECT_EQ(sync.next_deadline_ns(), 160 * kMs);
    ASSERT_TRUE(sync.poll(141 * kMs).has_value());  // the first was complete
    EXPECT_EQ(sync.next_deadline_ns(), 200 * kMs);
    EXPECT_FALSE(sync.poll(199 * kMs).has_value());
    ASSERT_TRUE(sync.poll(200 * kMs).has_value());  // left at its deadline, partial
    EXPECT_FALSE(sync.next_deadline_ns().has_value());
}

TEST(FrameSynchroniser, LateScanOfAFinishedFrameIsDroppedAndCounted) {
    FrameSynchroniser<int> sync(2, params());
    sync.push(0, 1000 * kMs, 0, 1);
    ASSERT_TRUE(sync.poll(100 * kMs).has_value());  // left without sensor 1
    sync.push(1, 1010 * kMs, 101 * kMs, 2);         // belonged to that frame
    sync.push(1, 900 * kMs, 102 * kMs, 3);          // older still
    EXPECT_EQ(sync.counters().late_dropped, 2u);
    EXPECT_EQ(sync.open_frames(), 0u);
}

TEST(FrameSynchroniser, LargeBackwardJumpResets) {
    FrameSynchroniser<int> sync(1, params());
    sync.push(0, 100'000 * kMs, 0, 1);
    ASSERT_TRUE(sync.poll(0).has_value());
    sync.push(0, 1'000 * kMs, 1 * kMs, 2);  // a looped replay starts over
    EXPECT_EQ(sync.counters().resets, 1u);
    auto frame = sync.poll(1 * kMs);
    ASSERT_TRUE(frame.has_value());
    EXPECT_EQ(frame->t_ns, 1'000 * kMs);
}

TEST(FrameSynchroniser, TimeOffsetsAlignSensors) {
    auto p = params();
    p.time_offset_ns = {0, -37'000'000'000LL};  // sensor 1 runs on TAI, 37 s ahead
    FrameSynchroniser<int> sync(2, p);
    sync.push(0, 5'000 * kMs, 0, 1);
    sync.push(1, 5'000 * kMs + 37'000'000'000LL + 2 * kMs, 0, 2);
    auto frame = sync.poll(0);
    ASSERT_TRUE(frame.has_value());
    EXPECT_EQ(frame->included(), 2u);
}

TEST(FrameSynchroniser, ANewerCompleteFramePushesOlderPartialsOutFirst) {
    FrameSynchroniser<int> sync(2, params());
    sync.push(0, 1000 * kMs, 0, 1);  // sensor 1 never sends this frame
    sync.push(0, 1050 * kMs, 1 * kMs, 2);
    sync.push(1, 1051 * kMs, 2 * kMs, 3);
    auto first = sync.poll(3 * kMs);
    auto second = sync.poll(3 * kMs);
    ASSERT_TRUE(first && second);
    EXPECT_EQ(first->t_ns, 1000 * kMs);
    EXPECT_EQ(first->included(), 1u);
    EXPECT_EQ(second->t_ns, 1050 * kMs);
    EXPECT_EQ(second->included(), 2u);
}

// Four sensors at 20 Hz with phase offsets, jittered arrival order, dropped scans and a
// late straggler now and then: output time strictly increases and every member lies within
// max_offset of its frame's reference.
TEST(FrameSynchroniser, RandomisedStreamsNeverGoBackwards) {
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> jitter(0, 8);
    std::bernoulli_distribution drop(0.05), straggle(0.03);
    const std::int64_t phase[4] = {0, 7 * kMs, 13 * kMs, 21 * kMs};
    FrameSynchroniser<std::int64_t> sync(4, params());
    std::vector<SyncedFrame<std::int64_t>> out;
    for (int f = 0; f < 500; ++f) {
        std::vector<std::pair<std::int64_t, int>> arrivals;
        for (int s = 0; s < 4; ++s) {
            if (drop(rng)) continue;
            const std::int64_t t = f * 50 * kMs + phase[s];
            const std::int64_t arrive = t + (straggle(rng) ? 90 * kMs : jitter(rng) * kMs);
            arrivals.emplace_back(arrive, s);
        }
        std::sort(arrivals.begin(), arrivals.end());
        for (const auto& [arrive, s] : arrivals) {
            const std::int64_t t = f * 50 * kMs + phase[s];
            sync.push(static_cast<std::size_t>(s), t, arrive, t);
            while (auto frame = sync.poll(arrive)) out.push_back(std::move(*frame));
        }
    }
    while (auto frame = sync.poll(1'000'000 * kMs)) out.push_back(std::move(*frame));
    ASSERT_GT(out.size(), 450u);
    for (std::size_t i = 1; i < out.size(); ++i) ASSERT_GT(out[i].t_ns, out[i - 1].t_ns);
    for (const auto& frame : out) {
        for (std::size_t s = 0; s < 4; ++s) {
            if (frame.members[s]) {
                EXPECT_GE(*frame.members[s], frame.t_ns);
                EXPECT_LT(*frame.members[s] - frame.t_ns, 50 * kMs);
            }
        }
    }
    const auto& c = sync.counters();
    EXPECT_EQ(c.frames_complete + c.frames_partial, out.size());
    EXPECT_GT(c.frames_complete, 300u);
}

}  // namespace
// fuse and calibrate group a recording's scans alike: one frame period, 1.5 periods' wait.
TEST(FrameSynchroniser, OfflineParamsFollowTheFrameRate) {
    EXPECT_EQ(offline_sync_params(20).max_offset_ns, 50'000'000);
    EXPECT_EQ(offline_sync_params(20).deadline_ns, 75'000'000);
    EXPECT_EQ(offline_sync_params(10).max_offset_ns, 100'000'000);
    EXPECT_EQ(offline_sync_params(10).deadline_ns, 150'000'000);
    EXPECT_EQ(offline_sync_params(0).max_offset_ns, 1'000'000'000);  // unknown rate: 1 Hz
}

}  // namespace lidarfuse::core
