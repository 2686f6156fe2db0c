#include "daemon/doorbell.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace lidarfuse::daemon {
namespace {

using Clock = std::chrono::steady_clock;

TEST(Doorbell, AWaitEndsAtItsDeadlineWhenNobodyRings) {
    Doorbell bell;
    EXPECT_FALSE(bell.wait_until(Clock::now() + std::chrono::milliseconds(5)));
}

TEST(Doorbell, ARingBeforeTheWaitIsKeptAndServesOneWait) {
    Doorbell bell;
    bell.ring();
    bell.ring();  // rings do not add up: one wait takes them all
    EXPECT_TRUE(bell.wait_until(Clock::now() + std::chrono::hours(1)));
    EXPECT_FALSE(bell.wait_until(Clock::now() + std::chrono::milliseconds(5)));
}

TEST(Doorbell, ARingFromAnotherThreadWakesTheWaiter) {
    Doorbell bell;
    std::thread ringer([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        bell.ring();
    });
    // An hour's deadline: true only if the ring woke it.
    EXPECT_TRUE(bell.wait_until(Clock::now() + std::chrono::hours(1)));
    ringer.join();
}

}  // namespace
}  // namespace lidarfuse::daemon
