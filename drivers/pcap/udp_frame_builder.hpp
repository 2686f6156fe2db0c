#pragma once
// Builds the Ethernet frames that carry one UDP/IPv4 datagram on the wire: whole, or split
// into IPv4 fragments at an MTU the way a Linux sender does (every fragment but the last
// carries (mtu - 20) rounded down to 8 bytes of IP payload; 1480 at MTU 1500, so a 12,608 B
// Ouster packet becomes 9 frames). IPv4 header and UDP checksums are valid.
// Used by PcapWriter and by tests that reorder, duplicate or corrupt fragments.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lidarfuse::pcap {

struct UdpEndpoints {
    std::uint32_t src_ip = 0;  // host byte order
    std::uint16_t src_port = 0;
    std::uint32_t dst_ip = 0;
    std::uint16_t dst_port = 0;
};

// Largest UDP payload in one IPv4 datagram: 65535 - 20 (IPv4) - 8 (UDP).
constexpr std::size_t kMaxUdpPayloadBytes = 65507;
constexpr std::size_t kEthernetMtuBytes = 1500;

// Replaces `frames` with the Ethernet frames of one datagram (inner vectors keep their
// capacity across calls). `mtu_bytes` = 0 writes one frame whatever its size (like a
// loopback capture). `udp_checksum` false writes 0, IPv4's "no checksum" (a recorder that
// writes 64 MB/s does not sum every byte). Throws std::invalid_argument when `size` exceeds
// kMaxUdpPayloadBytes or the MTU is below 68 bytes (RFC 791 minimum).
void build_udp_frames(const UdpEndpoints& endpoints, std::uint16_t ip_id, const std::uint8_t* data,
                      std::size_t size, std::size_t mtu_bytes,
                      std::vector<std::vector<std::uint8_t>>* frames, bool udp_checksum = true);

// RFC 1071 ones' complement sum folded to 16 bits (not yet inverted), big-endian words.
std::uint32_t internet_checksum_add(std::uint32_t sum, const std::uint8_t* data, std::size_t size);
std::uint16_t internet_checksum_finish(std::uint32_t sum);

}  // namespace lidarfuse::pcap
