// PcapReader on the real Ouster captures: golden datagram counts and sizes, reassembly of
// IPv4 fragments (including a stray fragment reusing the IP id), bad files.
#include "drivers/pcap/pcap_reader.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <stdexcept>
#include <vector>

#include "tests/support/test_data.hpp"

namespace lidarfuse::pcap {
namespace {

struct Datagram {
    std::int64_t timestamp_ns;
    std::uint32_t src_ip, dst_ip;
    std::uint16_t src_port, dst_port;
    std::vector<std::uint8_t> data;
    bool reassembled;
};

std::vector<Datagram> read_all(PcapReader& reader) {
    std::vector<Datagram> out;
    UdpDatagram d;
    while (reader.next(&d)) {
        out.push_back({d.timestamp_ns, d.src_ip, d.dst_ip, d.src_port, d.dst_port,
                       std::vector<std::uint8_t>(d.data, d.data + d.size), d.reassembled});
    }
    return out;
}

constexpr std::uint32_t ipv4(unsigned a, unsigned b, unsigned c, unsigned d) {
    return (a << 24) | (b << 16) | (c << 8) | d;
}

TEST(PcapReader, DuplicateIdYieldsOneDatagramAndDiscardsTheStrayFragment) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "duplicate_id.pcap");
    PcapReader reader(file);
    const auto all = read_all(reader);
    ASSERT_EQ(all.size(), 1u);
    EXPECT_EQ(all[0].data.size(), 8448u);
    EXPECT_EQ(all[0].dst_port, 34636);
    EXPECT_EQ(all[0].src_port, 50474);
    EXPECT_EQ(all[0].src_ip, ipv4(10, 5, 6, 101));
    EXPECT_EQ(all[0].dst_ip, ipv4(10, 5, 6, 1));
    EXPECT_TRUE(all[0].reassembled);
    // Timestamp of the last fragment (record 7: 1697084088.551171 s).
    EXPECT_EQ(all[0].timestamp_ns, 1697084088LL * 1000000000LL + 551171000LL);
    // Ouster RNG15 packet header: packet type 1, frame id 1778 (0x06F2) little-endian.
    EXPECT_EQ(all[0].data[0], 1);
    EXPECT_EQ(all[0].data[2] | (all[0].data[3] << 8), 1778);
    const auto& s = reader.stats();
    EXPECT_EQ(s.records, 7u);
    EXPECT_EQ(s.fragments, 7u);
    EXPECT_EQ(s.reassembled, 1u);
    EXPECT_EQ(s.dropped_incomplete, 1u);  // the stray, 88 s older: timed out
    EXPECT_EQ(s.discarded_fragments, 1u);
    EXPECT_EQ(s.cut_off, 0u);
    EXPECT_TRUE(reader.warning().empty());
}

TEST(PcapReader, DuplicateIdWithoutTimeOutDiscardsTheStrayByIdReuse) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "duplicate_id.pcap");
    PcapReaderParams params;
    params.reassembly.timeout_ns = std::int64_t{1000} * 1'000'000'000;  // 1000 s
    PcapReader reader(file, params);
    const auto all = read_all(reader);
    ASSERT_EQ(all.size(), 1u);
    EXPECT_EQ(all[0].data.size(), 8448u);
    EXPECT_EQ(all[0].data[2] | (all[0].data[3] << 8), 1778);
    EXPECT_EQ(reader.stats().dropped_incomplete, 1u);
    EXPECT_EQ(reader.stats().discarded_fragments, 1u);
}

TEST(PcapReader, SamePortsLegacyYieldsTwoReassembledDatagramsOnOnePort) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "same_ports_legacy.pcap");
    PcapReader reader(file);
    const auto all = read_all(reader);
    ASSERT_EQ(all.size(), 2u);
    EXPECT_EQ(all[0].src_ip, ipv4(169, 254, 238, 111));
    EXPECT_EQ(all[0].data.size(), 12608u);
    EXPECT_EQ(all[1].src_ip, ipv4(169, 254, 92, 158));
    EXPECT_EQ(all[1].data.size(), 24896u);
    for (const auto& d : all) {
        EXPECT_EQ(d.dst_port, 7502);
        EXPECT_EQ(d.dst_ip, ipv4(169, 254, 100, 204));
        EXPECT_TRUE(d.reassembled);
    }
    EXPECT_EQ(reader.stats().records, 26u);
    EXPECT_EQ(reader.stats().fragments, 26u);
    EXPECT_EQ(reader.stats().reassembled, 2u);
    EXPECT_EQ(reader.stats().dropped_incomplete, 0u);
}

TEST(PcapReader, Os1LegacyCaptureHas64LidarAnd11ImuDatagrams) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "OS-1-64_1024x10_fw20.pcap");
    PcapReader reader(file);
    const auto all = read_all(reader);
    int lidar = 0, imu = 0;
    for (const auto& d : all) {
        if (d.dst_port == 7502 && d.data.size() == 12608) ++lidar;
        if (d.dst_port == 7503 && d.data.size() == 48) ++imu;
        EXPECT_FALSE(d.reassembled);  // a loopback capture: whole datagrams
    }
    EXPECT_EQ(lidar, 64);
    EXPECT_EQ(imu, 11);
    EXPECT_EQ(all.size(), 75u);
    EXPECT_EQ(reader.stats().records, 75u);
    EXPECT_EQ(reader.stats().udp_datagrams, 75u);
    for (std::size_t i = 1; i < all.size(); ++i) {
        EXPECT_GE(all[i].timestamp_ns, all[i - 1].timestamp_ns);
    }
    EXPECT_LT(all.back().timestamp_ns - all.front().timestamp_ns, 100'000'000);
}

TEST(PcapReader, EveryCaptureReadsCleanly) {
    for (const char* name : {"OS-2-128-U1_v2.3.0_1024x10.pcap", "OS-0-128-U1_v2.3.0_1024x10.pcap",
                             "OS-1-32-G_v2.1.1_1024x10.pcap", "OS-0-32-U1_v2.2.0_1024x10.pcap",
                             "same_ports_nonlegacy.pcap", "same_ports.pcap", "crc_test.pcap",
                             "windowed_frame1.pcap", "windowed_frame2.pcap"}) {
        const auto file = test::ouster_file(name);
        if (!file) GTEST_SKIP() << name << " not found";
        PcapReader reader(*file);
        const auto all = read_all(reader);
        EXPECT_GT(all.size(), 0u) << name;
        const auto& s = reader.stats();
        EXPECT_EQ(s.malformed + s.truncated_records + s.non_ipv4 + s.non_udp, 0u) << name;
        EXPECT_EQ(s.dropped_incomplete, 0u) << name;
        EXPECT_EQ(s.cut_off + s.read_errors, 0u) << name;
    }
}

TEST(PcapReader, CutOffCaptureDeliversEverythingBeforeTheCutAndReportsIt) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "OS-1-64_1024x10_fw20.pcap");
    PcapReader full_reader(file);
    const auto full = read_all(full_reader);

    std::ifstream in(file, std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    test::TempDir dir("pcap_cut");
    // Cut in the middle of a record's data, then in the middle of a record header.
    // Each record is 16 header bytes + payload, so find record boundaries by walking.
    std::vector<std::size_t> record_starts;
    for (std::size_t off = 24; off + 16 <= bytes.size();) {
        record_starts.push_back(off);
        std::uint32_t caplen;
        std::memcpy(&caplen, &bytes[off + 8], 4);
        off += 16 + caplen;
    }
    ASSERT_EQ(record_starts.size(), 75u);
    struct Cut {
        std::size_t at;
        std::size_t complete_records;
    };
    for (const Cut cut : {Cut{record_starts[40] + 16 + 100, 40}, Cut{record_starts[50] + 7, 50}}) {
        const auto cut_file = dir.path() / "cut.pcap";
        std::ofstream(cut_file, std::ios::binary)
            .write(bytes.data(), static_cast<std::streamsize>(cut.at));
        PcapReader reader(cut_file);
        const auto got = read_all(reader);
        ASSERT_EQ(got.size(), cut.complete_records);
        for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].data, full[i].data);
        EXPECT_EQ(reader.stats().cut_off, 1u);
        EXPECT_NE(reader.warning().find(cut_file.string()), std::string::npos) << reader.warning();
        UdpDatagram d;
        EXPECT_FALSE(reader.next(&d));  // stays at the end
    }
}

TEST(PcapReader, RandomBytesAreAClearErrorNamingTheFile) {
    test::TempDir dir("pcap_random");
    const auto file = dir.path() / "random.pcap";
    std::mt19937 rng(7);
    std::vector<char> bytes(4096);
    for (auto& b : bytes) b = static_cast<char>(rng());
    std::ofstream(file, std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    try {
        PcapReader reader(file);
        FAIL() << "random bytes were accepted as a capture";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
}

TEST(PcapReader, MissingFileIsAClearErrorNamingTheFile) {
    const std::filesystem::path file = "/nonexistent/lidarfuse/capture.pcap";
    try {
        PcapReader reader(file);
        FAIL();
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace lidarfuse::pcap
