// PcapReader over every supported link layer (Ethernet + VLAN/QinQ, SLL, SLL2, raw IPv4,
// BSD loopback), pcapng, and the records it must skip (IPv6, ARP, TCP, truncated).
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <vector>

#include "drivers/pcap/pcap_reader.hpp"
#include "drivers/pcap/udp_frame_builder.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::pcap {
namespace {

using Bytes = std::vector<std::uint8_t>;
using Transform = std::function<Bytes(const Bytes& ethernet_frame)>;

void le32(Bytes* out, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out->push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void le16(Bytes* out, std::uint32_t v) {
    out->push_back(static_cast<std::uint8_t>(v));
    out->push_back(static_cast<std::uint8_t>(v >> 8));
}
void be16(Bytes* out, std::uint32_t v) {
    out->push_back(static_cast<std::uint8_t>(v >> 8));
    out->push_back(static_cast<std::uint8_t>(v));
}

// Classic microsecond pcap with an arbitrary link type.
void write_classic(const std::filesystem::path& file, std::uint32_t link_type,
                   const std::vector<Bytes>& frames, std::uint32_t extra_wire_bytes = 0) {
    Bytes out;
    le32(&out, 0xA1B2C3D4u);
    le16(&out, 2);
    le16(&out, 4);
    le32(&out, 0);
    le32(&out, 0);
    le32(&out, 262144);
    le32(&out, link_type);
    std::uint32_t t = 0;
    for (const auto& f : frames) {
        le32(&out, 1000);
        le32(&out, t++);
        le32(&out, static_cast<std::uint32_t>(f.size()));
        le32(&out, static_cast<std::uint32_t>(f.size()) + extra_wire_bytes);
        out.insert(out.end(), f.begin(), f.end());
    }
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char*>(out.data()), static_cast<std::streamsize>(out.size()));
}

// Minimal pcapng: section header, one Ethernet interface with if_tsresol = 9 (ns), and an
// enhanced packet block per frame.
void write_pcapng(const std::filesystem::path& file, const std::vector<Bytes>& frames,
                  std::uint64_t first_ts_ns) {
    Bytes out;
    le32(&out, 0x0A0D0D0A);
    le32(&out, 28);
    le32(&out, 0x1A2B3C4D);
    le16(&out, 1);
    le16(&out, 0);
    le32(&out, 0xFFFFFFFF);
    le32(&out, 0xFFFFFFFF);  // section length unknown
    le32(&out, 28);
    le32(&out, 1);  // interface description block
    le32(&out, 32);
    le16(&out, 1);  // Ethernet
    le16(&out, 0);
    le32(&out, 262144);
    le16(&out, 9);  // if_tsresol
    le16(&out, 1);
    out.insert(out.end(), {9, 0, 0, 0});
    le32(&out, 0);  // opt_endofopt
    le32(&out, 32);
    std::uint64_t ts = first_ts_ns;
    for (const auto& f : frames) {
        const std::uint32_t padded = static_cast<std::uint32_t>((f.size() + 3) / 4 * 4);
        const std::uint32_t total = 32 + padded;
        le32(&out, 6);
        le32(&out, total);
        le32(&out, 0);
        le32(&out, static_cast<std::uint32_t>(ts >> 32));
        le32(&out, static_cast<std::uint32_t>(ts));
        le32(&out, static_cast<std::uint32_t>(f.size()));
        le32(&out, static_cast<std::uint32_t>(f.size()));
        out.insert(out.end(), f.begin(), f.end());
        out.resize(out.size() + (padded - f.size()), 0);
        le32(&out, total);
        ts += 7;
    }
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char*>(out.data()), static_cast<std::streamsize>(out.size()));
}

Bytes payload(std::size_t size) {
    Bytes out(size);
    for (std::size_t i = 0; i < size; ++i) out[i] = static_cast<std::uint8_t>(i * 31 + 7);
    return out;
}

// Ethernet frames of a 3,000 B (3 fragments) and a 100 B datagram.
std::vector<Bytes> ethernet_frames() {
    std::vector<Bytes> all, frames;
    const auto big = payload(3000), small = payload(100);
    build_udp_frames({0xC0A80102, 7502, 0xC0A80101, 7502}, 77, big.data(), big.size(), 1500,
                     &frames);
    all.insert(all.end(), frames.begin(), frames.end());
    build_udp_frames({0xC0A80103, 7503, 0xC0A80101, 7503}, 78, small.data(), small.size(), 1500,
                     &frames);
    all.insert(all.end(), frames.begin(), frames.end());
    return all;
}

void expect_two_datagrams(const std::filesystem::path& file) {
    PcapReader reader(file);
    UdpDatagram d;
    ASSERT_TRUE(reader.next(&d));
    EXPECT_EQ(d.src_ip, 0xC0A80102u);
    EXPECT_EQ(d.dst_port, 7502);
    ASSERT_EQ(d.size, 3000u);
    const auto big = payload(3000);
    EXPECT_EQ(std::memcmp(d.data, big.data(), big.size()), 0);
    EXPECT_TRUE(d.reassembled);
    ASSERT_TRUE(reader.next(&d));
    EXPECT_EQ(d.src_ip, 0xC0A80103u);
    EXPECT_EQ(d.dst_port, 7503);
    ASSERT_EQ(d.size, 100u);
    EXPECT_FALSE(reader.next(&d));
    EXPECT_EQ(reader.stats().records, 4u);
    EXPECT_EQ(reader.stats().udp_datagrams, 2u);
}

std::vector<Bytes> transformed(const Transform& t) {
    std::vector<Bytes> out;
    for (const auto& f : ethernet_frames()) out.push_back(t(f));
    return out;
}

Bytes ip_part(const Bytes& eth) { return Bytes(eth.begin() + 14, eth.end()); }

TEST(PcapLinkTypes, Ethernet) {
    test::TempDir dir("link");
    write_classic(dir.path() / "a.pcap", 1, ethernet_frames());
    expect_two_datagrams(dir.path() / "a.pcap");
}

TEST(PcapLinkTypes, EthernetWithVlanAndQinQTags) {
    test::TempDir dir("link");
    write_classic(dir.path() / "vlan.pcap", 1, transformed([](const Bytes& e) {
                      Bytes out(e.begin(), e.begin() + 12);
                      be16(&out, 0x8100);
                      be16(&out, 0x0123);
                      out.insert(out.end(), e.begin() + 12, e.end());
                      return out;
                  }));
    expect_two_datagrams(dir.path() / "vlan.pcap");
    write_classic(dir.path() / "qinq.pcap", 1, transformed([](const Bytes& e) {
                      Bytes out(e.begin(), e.begin() + 12);
                      be16(&out, 0x88A8);
                      be16(&out, 0x0064);
                      be16(&out, 0x8100);
                      be16(&out, 0x0123);
                      out.insert(out.end(), e.begin() + 12, e.end());
                      return out;
                  }));
    expect_two_datagrams(dir.path() / "qinq.pcap");
}

TEST(PcapLinkTypes, LinuxCookedSllAndSll2) {
    test::TempDir dir("link");
    write_classic(dir.path() / "sll.pcap", 113, transformed([](const Bytes& e) {
                      Bytes out;
                      be16(&out, 0);  // packet type: to us
                      be16(&out, 1);  // ARPHRD_ETHER
                      be16(&out, 6);
                      out.insert(out.end(), e.begin() + 6, e.begin() + 12);
                      out.insert(out.end(), {0, 0});
                      be16(&out, 0x0800);
                      const Bytes ip = ip_part(e);
                      out.insert(out.end(), ip.begin(), ip.end());
                      return out;
                  }));
    expect_two_datagrams(dir.path() / "sll.pcap");
    write_classic(dir.path() / "sll2.pcap", 276, transformed([](const Bytes& e) {
                      Bytes out;
                      be16(&out, 0x0800);
                      be16(&out, 0);
                      out.insert(out.end(), {0, 0, 0, 3});  // interface index
                      be16(&out, 1);
                      out.push_back(0);
                      out.push_back(6);
                      out.insert(out.end(), e.begin() + 6, e.begin() + 12);
                      out.insert(out.end(), {0, 0});
                      const Bytes ip = ip_part(e);
                      out.insert(out.end(), ip.begin(), ip.end());
                      return out;
                  }));
    expect_two_datagrams(dir.path() / "sll2.pcap");
}

TEST(PcapLinkTypes, RawIpv4AndLoopback) {
    test::TempDir dir("link");
    for (const std::uint32_t link : {101u, 228u}) {
        write_classic(dir.path() / "raw.pcap", link, transformed(ip_part));
        expect_two_datagrams(dir.path() / "raw.pcap");
    }
    write_classic(dir.path() / "null.pcap", 0, transformed([](const Bytes& e) {
                      Bytes out = {2, 0, 0, 0};
                      const Bytes ip = ip_part(e);
                      out.insert(out.end(), ip.begin(), ip.end());
                      return out;
                  }));
    expect_two_datagrams(dir.path() / "null.pcap");
}

TEST(PcapLinkTypes, PcapngWithNanosecondResolution) {
    test::TempDir dir("link");
    write_pcapng(dir.path() / "a.pcapng", ethernet_frames(), 1'600'000'000'000'000'123ULL);
    expect_two_datagrams(dir.path() / "a.pcapng");
    PcapReader reader(dir.path() / "a.pcapng");
    UdpDatagram d;
    ASSERT_TRUE(reader.next(&d));
    EXPECT_EQ(d.timestamp_ns, 1'600'000'000'000'000'123LL + 2 * 7);  // third record completes
}

TEST(PcapLinkTypes, NonUdpNonIpv4AndTruncatedRecordsAreSkippedAndCounted) {
    test::TempDir dir("link");
    auto frames = ethernet_frames();
    Bytes ipv6 = frames.back();
    ipv6[12] = 0x86;
    ipv6[13] = 0xDD;
    Bytes arp(42, 0);
    arp[12] = 0x08;
    arp[13] = 0x06;
    Bytes tcp = frames.back();
    tcp[14 + 9] = 6;
    Bytes short_ip = frames.back();
    short_ip.resize(30);  // IPv4 header cut short: malformed
    frames.insert(frames.begin() + 1, {ipv6, arp, tcp, short_ip});
    write_classic(dir.path() / "mixed.pcap", 1, frames);
    PcapReader reader(dir.path() / "mixed.pcap");
    UdpDatagram d;
    int n = 0;
    while (reader.next(&d)) ++n;
    EXPECT_EQ(n, 2);
    EXPECT_EQ(reader.stats().non_ipv4, 2u);
    EXPECT_EQ(reader.stats().non_udp, 1u);
    EXPECT_EQ(reader.stats().malformed, 1u);

    write_classic(dir.path() / "truncated.pcap", 1, ethernet_frames(), 10);
    PcapReader truncated(dir.path() / "truncated.pcap");
    EXPECT_FALSE(truncated.next(&d));
    EXPECT_EQ(truncated.stats().truncated_records, 4u);
}

TEST(PcapLinkTypes, UnsupportedLinkTypeIsAnErrorNamingTheFile) {
    test::TempDir dir("link");
    const auto file = dir.path() / "wifi.pcap";
    write_classic(file, 105, {});  // IEEE 802.11
    try {
        PcapReader reader(file);
        FAIL();
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("link type"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace lidarfuse::pcap
