// The receiving side of one sensor, fed packets directly (no socket): what a scan message
// holds, and that a scan fusion gave back carries the next one.
#include "daemon/sensor_ingest.hpp"

#include <gtest/gtest.h>

#include <mutex>
#include <optional>

#include "tests/drivers/ouster_packet_rig.hpp"

namespace lidarfuse::daemon {
namespace {

// A sensor whose metadata the receiver thread would install, its scans into `queue`.
void install(SensorIngest* sensor, std::size_t index, DropOldestQueue<ScanMessage>* queue) {
    sensor->index = index;
    sensor->udp_port = 7502;
    {
        std::lock_guard<std::mutex> lock(sensor->pending_mutex);
        sensor->pending_info = ouster::packet_rig::make_info(ouster::UdpProfileLidar::kLegacy);
        // The rig's column times are 1 us apart in frames 1 s apart: no frame rate they
        // could agree with, so none to check them against (ModeCheck).
        sensor->pending_info->frames_per_second = 0;
    }
    sensor->has_pending.store(true);
    ASSERT_TRUE(sensor->install_pending_metadata(0.0, queue));
}

// Every packet of `frame`, in order: the assembler emits the scan when its last one is in.
void send_frame(SensorIngest* sensor, ouster::packet_rig::PacketWriter* writer,
                std::uint32_t frame) {
    for (int c = 0; c < 64; c += 8) {
        const auto& p = writer->packet(frame, c);
        sensor->assembler->add_packet(p.data(), p.size());
    }
}

TEST(SensorIngest, AScanGivenBackCarriesTheNextWithEveryFieldFilled) {
    DropOldestQueue<ScanMessage> queue(8), fresh_queue(8);
    SensorIngest sensor, fresh;
    ASSERT_NO_FATAL_FAILURE(install(&sensor, 2, &queue));
    ASSERT_NO_FATAL_FAILURE(install(&fresh, 2, &fresh_queue));
    ouster::packet_rig::PacketWriter writer(sensor.info);
    send_frame(&sensor, &writer, 1);
    std::optional<ScanMessage> first = queue.try_pop();
    ASSERT_TRUE(first.has_value());
    EXPECT_EQ(first->sensor, 2u);
    EXPECT_GT(first->points.size(), 500u);
    EXPECT_EQ(first->point_dt_s.size(), first->points.size());
    EXPECT_EQ(first->intensity.size(), first->points.size());
    // Between scans the receiver holds no points buffer of its own: the message took it.
    EXPECT_EQ(sensor.cloud.cloud.points.capacity(), 0u);

    const Eigen::Vector3f* points = first->points.data();
    const float* times = first->point_dt_s.data();
    const float* intensity = first->intensity.data();
    sensor.spare_scans.give(std::move(*first));
    send_frame(&sensor, &writer, 2);
    send_frame(&fresh, &writer, 2);
    const std::optional<ScanMessage> second = queue.try_pop();
    const std::optional<ScanMessage> expected = fresh_queue.try_pop();
    ASSERT_TRUE(second.has_value());
    ASSERT_TRUE(expected.has_value());
    EXPECT_EQ(second->points.data(), points);
    EXPECT_EQ(second->point_dt_s.data(), times);
    EXPECT_EQ(second->intensity.data(), intensity);
    // The same message as a sensor that allocates afresh.
    EXPECT_EQ(second->sensor, 2u);
    EXPECT_EQ(second->t_ns, expected->t_ns);
    EXPECT_TRUE(second->points == expected->points);
    EXPECT_EQ(second->point_dt_s, expected->point_dt_s);
    EXPECT_EQ(second->intensity, expected->intensity);
    EXPECT_EQ(sensor.spare_scans.counters().reused, 1u);
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
    used.points.assign(5000, Eigen::Vector3f::Ones());
    used.point_dt_s.assign(5000, 0.01f);
    used.intensity.assign(5000, 7.0f);
    const Eigen::Vector3f* points = used.points.data();
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

// The network section reaches the receiver's socket: its address, buffer and the wait
// after a wake-up (ms in the config, us in the socket's parameters).
TEST(SensorIngest, AReceiverTakesTheNetworkSection) {
    NetworkConfig network;
    network.bind_address = "127.0.0.1";
    network.receive_buffer_bytes = 1 << 20;
    network.receive_coalesce_ms = 2.5;
    const station::StationConfig station;
    const std::unique_ptr<Receiver> r = make_receiver(0, {}, network, station, 0.0);
    EXPECT_EQ(r->socket->params().bind_address, "127.0.0.1");
    EXPECT_EQ(r->socket->params().requested_rcvbuf_bytes, 1 << 20);
    EXPECT_EQ(r->socket->params().coalesce_us, 2500);
}

}  // namespace
}  // namespace lidarfuse::daemon
