#include "drivers/pcap/udp_frame_builder.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace lidarfuse::pcap {

namespace {

constexpr std::size_t kEthernetHeaderBytes = 14;
constexpr std::size_t kIpv4HeaderBytes = 20;
constexpr std::size_t kUdpHeaderBytes = 8;
constexpr std::uint8_t kTtl = 64;
constexpr std::uint8_t kProtocolUdp = 17;

void put16(std::uint8_t* p, std::uint32_t v) {
    p[0] = static_cast<std::uint8_t>(v >> 8);
    p[1] = static_cast<std::uint8_t>(v);
}
void put32(std::uint8_t* p, std::uint32_t v) {
    put16(p, v >> 16);
    put16(p + 2, v & 0xFFFFu);
}

// Locally administered MAC addresses derived from the IPv4 address: 02:00:a.b.c.d.
void put_mac(std::uint8_t* p, std::uint32_t ip) {
    p[0] = 0x02;
    p[1] = 0x00;
    put32(p + 2, ip);
}

}  // namespace

std::uint32_t internet_checksum_add(std::uint32_t sum, const std::uint8_t* data, std::size_t size) {
    std::size_t i = 0;
    for (; i + 1 < size; i += 2) {
        sum += static_cast<std::uint32_t>((data[i] << 8) | data[i + 1]);
        if (sum > 0xFFFF0000u) sum = (sum & 0xFFFFu) + (sum >> 16);
    }
    if (i < size) sum += static_cast<std::uint32_t>(data[i] << 8);
    while (sum >> 16) sum = (sum & 0xFFFFu) + (sum >> 16);
    return sum;
}

std::uint16_t internet_checksum_finish(std::uint32_t sum) {
    while (sum >> 16) sum = (sum & 0xFFFFu) + (sum >> 16);
    return static_cast<std::uint16_t>(~sum & 0xFFFFu);
}

namespace {

void check_sizes(std::size_t size, std::size_t mtu_bytes) {
    if (size > kMaxUdpPayloadBytes) {
        throw std::invalid_argument("UDP payload of " + std::to_string(size) +
                                    " bytes exceeds the IPv4 limit of 65507");
    }
    if (mtu_bytes != 0 && mtu_bytes < 68) {
        throw std::invalid_argument("MTU of " + std::to_string(mtu_bytes) +
                                    " bytes is below the IPv4 minimum of 68");
    }
}

// UDP header + checksum over the pseudo-header, header and data (RFC 768); without
// udp_checksum the checksum field stays 0 ("no checksum").
void put_udp_header(const UdpEndpoints& ep, const std::uint8_t* data, std::size_t size,
                    bool udp_checksum, std::uint8_t* udp_header) {
    const std::size_t ip_payload_bytes = kUdpHeaderBytes + size;
    put16(udp_header, ep.src_port);
    put16(udp_header + 2, ep.dst_port);
    put16(udp_header + 4, static_cast<std::uint32_t>(ip_payload_bytes));
    put16(udp_header + 6, 0);
    std::uint8_t pseudo[12];
    put32(pseudo, ep.src_ip);
    put32(pseudo + 4, ep.dst_ip);
    pseudo[8] = 0;
    pseudo[9] = kProtocolUdp;
    put16(pseudo + 10, static_cast<std::uint32_t>(ip_payload_bytes));
    if (udp_checksum) {
        std::uint32_t sum = internet_checksum_add(0, pseudo, sizeof pseudo);
        sum = internet_checksum_add(sum, udp_header, kUdpHeaderBytes);
        sum = internet_checksum_add(sum, data, size);  // data starts at an even offset
        std::uint16_t checksum = internet_checksum_finish(sum);
        if (checksum == 0) checksum = 0xFFFF;  // 0 means "no checksum" in UDP/IPv4
        put16(udp_header + 6, checksum);
    }
}

// Ethernet and IPv4 headers of the fragment holding bytes [begin, end) of the IP payload;
// `more`: further fragments follow.
void put_frame_headers(const UdpEndpoints& ep, std::uint16_t ip_id, std::size_t begin,
                       std::size_t end, bool more, std::uint8_t* eth) {
    put_mac(eth, ep.dst_ip);
    put_mac(eth + 6, ep.src_ip);
    put16(eth + 12, 0x0800);
    std::uint8_t* ip = eth + kEthernetHeaderBytes;
    ip[0] = 0x45;  // version 4, 5 words
    ip[1] = 0;
    put16(ip + 2, static_cast<std::uint32_t>(kIpv4HeaderBytes + (end - begin)));
    put16(ip + 4, ip_id);
    put16(ip + 6, (more ? 0x2000u : 0u) | static_cast<std::uint32_t>(begin / 8));
    ip[8] = kTtl;
    ip[9] = kProtocolUdp;
    put16(ip + 10, 0);
    put32(ip + 12, ep.src_ip);
    put32(ip + 16, ep.dst_ip);
    put16(ip + 10, internet_checksum_finish(internet_checksum_add(0, ip, kIpv4HeaderBytes)));
}

// Copies the slice [begin, end) of (UDP header ++ data) to out.
void copy_slice(const std::uint8_t* udp_header, const std::uint8_t* data, std::size_t begin,
                std::size_t end, std::uint8_t* out) {
    for (std::size_t pos = begin; pos < end;) {
        if (pos < kUdpHeaderBytes) {
            const std::size_t n = std::min(kUdpHeaderBytes, end) - pos;
            std::memcpy(out, udp_header + pos, n);
            out += n;
            pos += n;
        } else {
            const std::size_t n = end - pos;
            if (n > 0) std::memcpy(out, data + (pos - kUdpHeaderBytes), n);
            out += n;
            pos += n;
        }
    }
}

}  // namespace

void build_udp_frames(const UdpEndpoints& ep, std::uint16_t ip_id, const std::uint8_t* data,
                      std::size_t size, std::size_t mtu_bytes,
                      std::vector<std::vector<std::uint8_t>>* frames, bool udp_checksum) {
    check_sizes(size, mtu_bytes);
    const std::size_t ip_payload_bytes = kUdpHeaderBytes + size;
    std::uint8_t udp_header[kUdpHeaderBytes];
    put_udp_header(ep, data, size, udp_checksum, udp_header);

    // Fragments carry multiples of 8 bytes of the IP payload (the offset field's unit).
    const std::size_t per_fragment =
        mtu_bytes == 0 ? ip_payload_bytes : ((mtu_bytes - kIpv4HeaderBytes) / 8) * 8;
    const std::size_t count =
        std::max<std::size_t>(1, (ip_payload_bytes + per_fragment - 1) / per_fragment);
    frames->resize(count);
    for (std::size_t i = 0; i < count; ++i) {
        const std::size_t begin = i * per_fragment;
        const std::size_t end = std::min(begin + per_fragment, ip_payload_bytes);
        auto& frame = (*frames)[i];
        frame.resize(kEthernetHeaderBytes + kIpv4HeaderBytes + (end - begin));
        put_frame_headers(ep, ip_id, begin, end, end < ip_payload_bytes, frame.data());
        copy_slice(udp_header, data, begin, end,
                   frame.data() + kEthernetHeaderBytes + kIpv4HeaderBytes);
    }
}

}  // namespace lidarfuse::pcap
