#pragma once
// One UDP/IPv4 datagram as delivered by PcapReader (whole, or reassembled from fragments).

#include <cstddef>
#include <cstdint>

namespace lidarfuse::pcap {

struct UdpDatagram {
    // Capture time of the record that completed the datagram (the last fragment to arrive),
    // in ns since the Unix epoch, as written by the capturing host.
    std::int64_t timestamp_ns = 0;
    std::uint32_t src_ip = 0;  // IPv4 addresses, host byte order (10.5.6.1 = 0x0A050601)
    std::uint32_t dst_ip = 0;
    std::uint16_t src_port = 0;
    std::uint16_t dst_port = 0;
    const std::uint8_t* data = nullptr;  // UDP payload (no headers); owned by the reader
    std::size_t size = 0;                // payload bytes
    bool reassembled = false;            // true when built from IPv4 fragments
};

}  // namespace lidarfuse::pcap
