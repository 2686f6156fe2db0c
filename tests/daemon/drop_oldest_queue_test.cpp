#include "daemon/drop_oldest_queue.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <thread>
#include <vector>

namespace lidarfuse::daemon {
namespace {

TEST(DropOldestQueue, FifoUpToItsCapacity) {
    DropOldestQueue<int> q(3);
    EXPECT_EQ(q.capacity(), 3u);
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(q.push(i));
    EXPECT_FALSE(q.push(3));  // a fourth does not fit in three, though the ring has four slots
    for (int i = 1; i < 4; ++i) EXPECT_EQ(q.try_pop().value(), i);
    EXPECT_FALSE(q.try_pop().has_value());
}

// sync.queue_depth: 1 holds one frame, the newest, not two (its ring has two slots).
TEST(DropOldestQueue, ACapacityOfOneKeepsOnlyTheNewest) {
    DropOldestQueue<int> q(1);
    EXPECT_EQ(q.capacity(), 1u);
    EXPECT_TRUE(q.push(0));
    EXPECT_FALSE(q.push(1));
    EXPECT_FALSE(q.push(2));
    EXPECT_EQ(q.dropped(), 2u);
    EXPECT_EQ(q.try_pop().value(), 2);
    EXPECT_TRUE(q.empty());
    EXPECT_TRUE(q.push(3));  // room again once the consumer took the one
    EXPECT_EQ(q.try_pop().value(), 3);
}

TEST(DropOldestQueue, FullQueueDropsTheOldestAndCountsIt) {
    DropOldestQueue<int> q(4);
    for (int i = 0; i < 4; ++i) q.push(i);
    EXPECT_FALSE(q.push(4));  // 0 dropped
    EXPECT_FALSE(q.push(5));  // 1 dropped
    EXPECT_EQ(q.dropped(), 2u);
    EXPECT_EQ(q.pushed(), 6u);
    std::vector<int> out;
    while (auto v = q.try_pop()) out.push_back(*v);
    EXPECT_EQ(out, (std::vector<int>{2, 3, 4, 5}));
}

TEST(DropOldestQueue, MoveOnlyItemsAreNotLeaked) {
    DropOldestQueue<std::unique_ptr<int>> q(2);
    for (int i = 0; i < 10; ++i) q.push(std::make_unique<int>(i));
    EXPECT_EQ(q.dropped(), 8u);
    EXPECT_EQ(*q.try_pop().value(), 8);
    // The remaining item is destroyed with the queue (ASan checks for leaks).
}

// A fast producer and a slower consumer: the consumer sees a strictly increasing
// sequence (no reordering, no duplicates) and every item is either consumed or counted.
// Capacities 1 and 3 (fewer items than ring slots) and 64.
class DropOldestQueueCapacity : public ::testing::TestWithParam<std::size_t> {};

TEST_P(DropOldestQueueCapacity, ConcurrentProducerConsumerKeepsOrderAndAccounts) {
    constexpr int kItems = 200000;
    DropOldestQueue<int> q(GetParam());
    std::vector<int> seen;
    seen.reserve(kItems);
    std::thread consumer([&] {
        for (;;) {
            auto v = q.pop_wait(std::chrono::seconds(30));
            if (!v) {
                if (q.closed()) break;
                continue;
            }
            seen.push_back(*v);
            if (seen.size() % 128 == 0) std::this_thread::yield();
        }
        while (auto v = q.try_pop()) seen.push_back(*v);
    });
    for (int i = 0; i < kItems; ++i) q.push(i);
    q.close();
    consumer.join();
    for (std::size_t i = 1; i < seen.size(); ++i) ASSERT_LT(seen[i - 1], seen[i]);
    EXPECT_EQ(seen.size() + q.dropped(), static_cast<std::size_t>(kItems));
    EXPECT_EQ(seen.back(), kItems - 1);  // the newest item is never the one dropped
}

INSTANTIATE_TEST_SUITE_P(Capacities, DropOldestQueueCapacity, ::testing::Values(1, 3, 64));

TEST(DropOldestQueue, CloseWakesAWaitingConsumer) {
    DropOldestQueue<int> q(8);
    std::thread consumer([&] { EXPECT_FALSE(q.pop_wait(std::chrono::hours(1)).has_value()); });
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    q.close();
    consumer.join();  // would hang for an hour if close() did not wake it
    EXPECT_TRUE(q.closed());
}

TEST(DropOldestQueue, PushWakesAWaitingConsumer) {
    DropOldestQueue<int> q(8);
    std::thread consumer([&] { EXPECT_EQ(q.pop_wait(std::chrono::hours(1)).value_or(-1), 42); });
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    q.push(42);
    consumer.join();
}

// A consumer of several queues sleeps on one doorbell: a push into any of them wakes it,
// and the item is there when it looks.
TEST(DropOldestQueue, PushIntoAnyOfSeveralQueuesRingsTheirDoorbell) {
    Doorbell bell;
    DropOldestQueue<int> a(4), b(4);
    a.set_doorbell(&bell);
    b.set_doorbell(&bell);
    const auto later = [] { return std::chrono::steady_clock::now() + std::chrono::hours(1); };
    std::thread producer([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        b.push(7);
    });
    EXPECT_TRUE(bell.wait_until(later()));  // would sleep for an hour without the ring
    producer.join();
    EXPECT_FALSE(a.try_pop().has_value());
    EXPECT_EQ(b.try_pop().value_or(-1), 7);
    a.push(1);  // a ring while nobody waits is kept for the next wait
    EXPECT_TRUE(bell.wait_until(later()));
}

}  // namespace
}  // namespace lidarfuse::daemon
