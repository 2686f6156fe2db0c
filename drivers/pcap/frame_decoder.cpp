#include "drivers/pcap/frame_decoder.hpp"

#include <pcap/pcap.h>

namespace lidarfuse::pcap {

namespace {

constexpr std::uint16_t kEtherTypeIpv4 = 0x0800;
constexpr std::uint16_t kEtherTypeVlan = 0x8100;        // 802.1Q
constexpr std::uint16_t kEtherTypeQinQ = 0x88A8;        // 802.1ad service tag
constexpr std::uint16_t kEtherTypeQinQLegacy = 0x9100;  // pre-standard QinQ
constexpr std::size_t kEthernetHeaderBytes = 14;
constexpr std::size_t kSllHeaderBytes = 16;
constexpr std::size_t kSll2HeaderBytes = 20;
constexpr std::size_t kVlanTagBytes = 4;

std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }
std::uint32_t be32(const std::uint8_t* p) {
    return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
           std::uint32_t{p[3]};
}

bool is_vlan(std::uint16_t ether_type) {
    return ether_type == kEtherTypeVlan || ether_type == kEtherTypeQinQ ||
           ether_type == kEtherTypeQinQLegacy;
}

// `ether_type` is the first type field, found `offset` bytes into the frame; VLAN tags (each
// 4 bytes: TCI then the next type) are skipped until a protocol appears.
FrameKind decode_ether_type_chain(std::uint16_t ether_type, const std::uint8_t* frame,
                                  std::size_t size, std::size_t offset, Ipv4Packet* out) {
    while (is_vlan(ether_type)) {
        if (size < offset + kVlanTagBytes) return FrameKind::kMalformed;
        ether_type = be16(frame + offset + 2);
        offset += kVlanTagBytes;
    }
    if (ether_type != kEtherTypeIpv4) return FrameKind::kNotIpv4;
    return decode_ipv4(frame + offset, size - offset, out);
}

}  // namespace

bool is_supported_link_type(int link_type) {
    switch (link_type) {
        case DLT_EN10MB:
        case DLT_LINUX_SLL:
        case DLT_LINUX_SLL2:
        case DLT_RAW:
        case DLT_IPV4:
        case DLT_NULL:
        case DLT_LOOP:
            return true;
        default:
            return false;
    }
}

FrameKind decode_frame(int link_type, const std::uint8_t* frame, std::size_t size,
                       Ipv4Packet* out) {
    switch (link_type) {
        case DLT_EN10MB:
            if (size < kEthernetHeaderBytes) return FrameKind::kMalformed;
            return decode_ether_type_chain(be16(frame + 12), frame, size, kEthernetHeaderBytes,
                                           out);
        case DLT_LINUX_SLL:
            if (size < kSllHeaderBytes) return FrameKind::kMalformed;
            return decode_ether_type_chain(be16(frame + 14), frame, size, kSllHeaderBytes, out);
        case DLT_LINUX_SLL2:
            if (size < kSll2HeaderBytes) return FrameKind::kMalformed;
            return decode_ether_type_chain(be16(frame), frame, size, kSll2HeaderBytes, out);
        case DLT_RAW:
        case DLT_IPV4:
            if (size < 1) return FrameKind::kMalformed;
            if ((frame[0] >> 4) != 4) return FrameKind::kNotIpv4;
            return decode_ipv4(frame, size, out);
        case DLT_NULL:
        case DLT_LOOP: {
            // 4-byte address family: host order of the capturing machine for DLT_NULL,
            // network order for DLT_LOOP. AF_INET is 2 everywhere.
            if (size < 4) return FrameKind::kMalformed;
            const bool inet = (frame[0] == 2 && frame[1] == 0 && frame[2] == 0 && frame[3] == 0) ||
                              (frame[0] == 0 && frame[1] == 0 && frame[2] == 0 && frame[3] == 2);
            if (!inet) return FrameKind::kNotIpv4;
            return decode_ipv4(frame + 4, size - 4, out);
        }
        default:
            return FrameKind::kUnsupportedLink;
    }
}

FrameKind decode_ipv4(const std::uint8_t* ip, std::size_t size, Ipv4Packet* out) {
    if (size < 20) return FrameKind::kMalformed;
    if ((ip[0] >> 4) != 4) return FrameKind::kNotIpv4;
    const std::size_t header_bytes = static_cast<std::size_t>(ip[0] & 0x0F) * 4;
    const std::size_t total_bytes = be16(ip + 2);
    if (header_bytes < 20 || total_bytes < header_bytes || total_bytes > size) {
        return FrameKind::kMalformed;
    }
    const std::uint16_t flags_offset = be16(ip + 6);
    out->id = be16(ip + 4);
    out->more_fragments = (flags_offset & 0x2000) != 0;
    out->offset_bytes = static_cast<std::uint32_t>(flags_offset & 0x1FFF) * 8;
    out->protocol = ip[9];
    out->src_ip = be32(ip + 12);
    out->dst_ip = be32(ip + 16);
    out->payload = ip + header_bytes;
    out->payload_size = total_bytes - header_bytes;
    return FrameKind::kIpv4;
}

bool decode_udp(const std::uint8_t* ip_payload, std::size_t size, UdpPayload* out) {
    if (size < 8) return false;
    const std::size_t udp_bytes = be16(ip_payload + 4);
    if (udp_bytes < 8 || udp_bytes > size) return false;
    out->src_port = be16(ip_payload);
    out->dst_port = be16(ip_payload + 2);
    out->data = ip_payload + 8;
    out->size = udp_bytes - 8;
    return true;
}

}  // namespace lidarfuse::pcap
