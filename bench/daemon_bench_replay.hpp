#pragma once
// daemon_latency_bench's replay: a simulated capture's datagrams sent to lidarfused's ports
// at recorded speed, with each scan's send time noted for the latency figures.

#include <cstdint>
#include <filesystem>
#include <map>
#include <vector>

#include "drivers/ouster/packet_format.hpp"

namespace lidarfuse::bench {

// One scan of one sensor as the replay sent it.
struct ScanSent {
    std::uint16_t min_measurement_id = 0xFFFF;
    std::uint64_t reference_ns = 0;  // timestamp of its first column (the daemon's scan time)
    std::int64_t last_send_ns = 0;   // monotonic time its last datagram left
};

struct SensorReplay {
    std::uint16_t capture_port = 0;  // destination port in the capture
    std::uint16_t send_port = 0;     // the daemon's port for this sensor
    int socket = -1;
    ouster::PacketFormat format;
    std::map<std::uint32_t, ScanSent> scans;  // by frame_id
    std::uint64_t datagrams = 0;
};

// Sends the capture's datagrams for the chosen sensors at recorded speed (absolute
// deadlines), noting per scan when its last datagram left.
void replay(const std::filesystem::path& capture, std::vector<SensorReplay>* sensors);

}  // namespace lidarfuse::bench
