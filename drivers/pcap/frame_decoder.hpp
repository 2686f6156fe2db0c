#pragma once
// Link-layer, IPv4 and UDP header decoding for captured frames. Pure functions over a byte
// range: they never read past `size`, never allocate, and never trust a length field.

#include <cstddef>
#include <cstdint>

namespace lidarfuse::pcap {

enum class FrameKind {
    kIpv4,             // an IPv4 packet was found and its header is sane
    kNotIpv4,          // another network protocol (ARP, IPv6, LLC, ...)
    kUnsupportedLink,  // a link type this decoder does not know
    kMalformed,        // too short, or inconsistent lengths
};

struct Ipv4Packet {
    std::uint32_t src_ip = 0;  // host byte order
    std::uint32_t dst_ip = 0;
    std::uint16_t id = 0;
    std::uint8_t protocol = 0;
    bool more_fragments = false;
    std::uint32_t offset_bytes = 0;         // fragment offset x 8
    const std::uint8_t* payload = nullptr;  // after the IPv4 header (options skipped)
    std::size_t payload_size = 0;  // from the total-length field (Ethernet padding dropped)

    bool is_fragment() const { return more_fragments || offset_bytes != 0; }
};

// Link types understood (DLT_* values as returned by pcap_datalink): Ethernet with any
// number of 802.1Q / 802.1ad / QinQ tags, Linux cooked SLL and SLL2, raw IP (DLT_RAW,
// DLT_IPV4) and BSD loopback (DLT_NULL, DLT_LOOP).
bool is_supported_link_type(int link_type);

// Finds and decodes the IPv4 header inside one captured frame.
FrameKind decode_frame(int link_type, const std::uint8_t* frame, std::size_t size, Ipv4Packet* out);

// Decodes an IPv4 packet that starts at `ip`.
FrameKind decode_ipv4(const std::uint8_t* ip, std::size_t size, Ipv4Packet* out);

struct UdpPayload {
    std::uint16_t src_port = 0;
    std::uint16_t dst_port = 0;
    const std::uint8_t* data = nullptr;
    std::size_t size = 0;
};

// Decodes the UDP header at the start of a (whole or reassembled) IPv4 payload. False when
// it is shorter than 8 bytes or its length field is below 8 or past the payload; the
// checksum is not verified (captures taken on the sending host often carry offloaded,
// unfilled checksums).
bool decode_udp(const std::uint8_t* ip_payload, std::size_t size, UdpPayload* out);

constexpr std::uint8_t kIpProtocolUdp = 17;

}  // namespace lidarfuse::pcap
