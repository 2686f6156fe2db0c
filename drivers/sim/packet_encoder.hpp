#pragma once
// Writes one Ouster lidar packet from rendered columns, through the same data-driven
// layout the ingest reads with (drivers/ouster/packet_format.hpp). Every column of a
// simulated packet is valid (status 0xFFFFFFFF for LEGACY, bit 0 set otherwise); LEGACY
// columns also carry frame_id and encoder count (90112 ticks per turn); STANDARD headers
// carry frame_id, init_id, serial and a CRC-64 footer (FW >= 3.0 behaviour).

#include <cstdint>

#include "drivers/ouster/packet_format.hpp"
#include "drivers/sim/sensor_model.hpp"

namespace lidarfuse::sim {

struct PacketHeaderValues {
    std::uint32_t frame_id = 0;
    std::uint32_t init_id = 0;
    std::uint64_t serial = 0;
};

// `pixels` holds columns_per_packet x pixels_per_column returns (column-major: column c,
// row r at c * rows + r); `timestamps_ns[c]` and measurement ids first_measurement_id + c.
// `pkt` must hold format.lidar_packet_size() bytes; it is overwritten entirely.
void encode_lidar_packet(const ouster::PacketFormat& format, const PacketHeaderValues& header,
                         int first_measurement_id, int columns_per_frame,
                         const std::uint64_t* timestamps_ns, const PixelReturn* pixels,
                         std::uint8_t* pkt);

}  // namespace lidarfuse::sim
