#include "daemon/buffer_pool.hpp"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

#include "daemon/drop_oldest_queue.hpp"
#include "daemon/sensor_ingest.hpp"

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
// spares, the producer stops allocating (TSan checks the hand-over).
TEST(BufferPool, BuffersCirculateBetweenAProducerAndAConsumer) {
    constexpr int kItems = 2000;
    BufferPool<std::vector<int>> pool(2);
    DropOldestQueue<std::vector<int>> queue(64);
    int allocated = 0;
    std::thread producer([&] {
        for (int i = 0; i < kItems; ++i) {
            std::vector<int> buffer = pool.take().value_or(std::vector<int>{});
            if (buffer.capacity() == 0) ++allocated;
            buffer.assign(256, i);
            queue.push(std::move(buffer));
            if (i % 16 == 0) std::this_thread::yield();
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

// A producer fills only what it has (a DDS input has no point times): a spare scan must
// not carry the last scan's values into the next, only its storage.
TEST(SensorIngest, ASpareScanIsEmptyButKeepsItsStorage) {
    SensorIngest sensor;
    sensor.index = 3;
    EXPECT_TRUE(sensor.take_spare_scan().points.empty());  // none kept: a new one
    ScanMessage used;
    used.sensor = 3;
    used.t_ns = 42;
    used.points.assign(5000, Eigen::Vector3d::Ones());
    used.point_dt_s.assign(5000, 0.01f);
    used.intensity.assign(5000, 7.0f);
    const Eigen::Vector3d* points = used.points.data();
    const float* times = used.point_dt_s.data();
    const float* intensity = used.intensity.data();
    sensor.spare_scans.give(std::move(used));
    const ScanMessage spare = sensor.take_spare_scan();
    EXPECT_EQ(spare.sensor, 3u);
    EXPECT_EQ(spare.t_ns, 0);
    EXPECT_TRUE(spare.points.empty());
    EXPECT_TRUE(spare.point_dt_s.empty());
    EXPECT_TRUE(spare.intensity.empty());
    EXPECT_EQ(spare.points.data(), points);
    EXPECT_EQ(spare.point_dt_s.data(), times);
    EXPECT_EQ(spare.intensity.data(), intensity);
    EXPECT_GE(spare.points.capacity(), 5000u);
}

}  // namespace
}  // namespace lidarfuse::daemon
