#include "daemon/buffer_pool.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "daemon/drop_oldest_queue.hpp"

namespace lidarfuse::daemon {
namespace {

TEST(BufferPool, AnEmptyPoolHandsOutNothingAndCountsTheMiss) {
    BufferPool<std::vector<int>> pool(2);
    EXPECT_FALSE(pool.take().has_value());
    EXPECT_EQ(pool.counters().missed, 1u);
    EXPECT_EQ(pool.counters().reused, 0u);
}

TEST(BufferPool, AGivenBufferComesBackWithItsStorage) {
    BufferPool<std::vector<int>> pool(2);
    std::vector<int> buffer(1000, 5);
    const int* storage = buffer.data();
    pool.give(std::move(buffer));
    EXPECT_EQ(pool.kept(), 1u);
    auto back = pool.take();
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(back->data(), storage);
    EXPECT_EQ(back->size(), 1000u);  // as given: the taker clears or overwrites it
    EXPECT_EQ(pool.kept(), 0u);
    EXPECT_EQ(pool.counters().reused, 1u);
}

TEST(BufferPool, KeepsAtMostMaxKeptAndFreesTheRest) {
    BufferPool<std::vector<int>> pool(2);
    for (int i = 0; i < 5; ++i) pool.give(std::vector<int>(100, i));
    EXPECT_EQ(pool.kept(), 2u);
    EXPECT_EQ(pool.counters().discarded, 3u);
    // The last kept is handed out first (its pages are the most recently touched).
    EXPECT_EQ(pool.take()->front(), 1);
    EXPECT_EQ(pool.take()->front(), 0);
    EXPECT_FALSE(pool.take().has_value());
}

// The daemon's pattern: a producer takes a spare or allocates, fills it and queues it; a
// consumer uses it and gives it back. Every buffer is accounted for and, once the pool has
// spares, the producer stops allocating (TSan checks the hand-over). The producer keeps at
// most kLead items ahead of the consumer, as a sensor's frames are paced: unpaced, on a
// busy machine it could queue all of them before the consumer first ran, and no buffer
// would come back to be reused.
TEST(BufferPool, BuffersCirculateBetweenAProducerAndAConsumer) {
    constexpr int kItems = 2000;
    constexpr int kLead = 8;
    BufferPool<std::vector<int>> pool(2);
    DropOldestQueue<std::vector<int>> queue(64);
    int allocated = 0;
    std::atomic<int> given_back{0};
    std::thread producer([&] {
        for (int i = 0; i < kItems; ++i) {
            while (i - given_back.load() > kLead) std::this_thread::yield();
            std::vector<int> buffer = pool.take().value_or(std::vector<int>{});
            if (buffer.capacity() == 0) ++allocated;
            buffer.assign(256, i);
            queue.push(std::move(buffer));
        }
        queue.close();
    });
    int received = 0;
    while (true) {
        auto item = queue.pop_wait(std::chrono::milliseconds(100));
        if (!item) {
            if (queue.closed() && queue.empty()) break;
            continue;
        }
        EXPECT_EQ(item->size(), 256u);
        EXPECT_EQ(item->front(), item->back());
        ++received;
        pool.give(std::move(*item));
        ++given_back;
    }
    producer.join();
    const auto c = pool.counters();
    EXPECT_EQ(c.reused + c.missed, static_cast<std::uint64_t>(kItems));
    EXPECT_EQ(static_cast<std::uint64_t>(allocated), c.missed);
    EXPECT_EQ(static_cast<std::uint64_t>(received) + queue.dropped(),
              static_cast<std::uint64_t>(kItems));
    EXPECT_GT(c.reused, 0u);
    EXPECT_LE(pool.kept(), 2u);
}

}  // namespace
}  // namespace lidarfuse::daemon
