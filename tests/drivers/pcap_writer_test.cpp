// PcapWriter -> PcapReader round trips: whole and fragmented datagrams of every size class,
// interleaved/reordered/duplicated fragments, both timestamp precisions, valid checksums,
// and fragment layout identical to a real capture.
#include "drivers/pcap/pcap_writer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <stdexcept>
#include <vector>

#include "drivers/pcap/pcap_reader.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::pcap {
namespace {

std::vector<std::uint8_t> pattern(std::size_t size, std::uint32_t seed) {
    std::vector<std::uint8_t> out(size);
    std::mt19937 rng(seed);
    for (auto& b : out) b = static_cast<std::uint8_t>(rng());
    return out;
}

struct Record {
    std::uint32_t ts_sec, ts_frac, caplen, len;
    std::vector<std::uint8_t> frame;
};

// Independent reader of a little-endian classic pcap, to check what the writer produced.
std::vector<Record> raw_records(const std::filesystem::path& file, std::uint32_t* magic) {
    std::ifstream in(file, std::ios::binary);
    std::vector<std::uint8_t> b((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
    auto le32 = [&](std::size_t at) {
        return std::uint32_t(b[at]) | std::uint32_t(b[at + 1]) << 8 |
               std::uint32_t(b[at + 2]) << 16 | std::uint32_t(b[at + 3]) << 24;
    };
    *magic = le32(0);
    std::vector<Record> out;
    for (std::size_t off = 24; off + 16 <= b.size();) {
        Record r{le32(off), le32(off + 4), le32(off + 8), le32(off + 12), {}};
        r.frame.assign(b.begin() + static_cast<long>(off + 16),
                       b.begin() + static_cast<long>(off + 16 + r.caplen));
        off += 16 + r.caplen;
        out.push_back(std::move(r));
    }
    return out;
}

std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] << 8 | p[1]); }

TEST(PcapWriter, RoundTripsWholeAndFragmentedDatagramsOfEverySize) {
    test::TempDir dir("pcap_writer");
    const std::vector<std::size_t> sizes = {0,    1,    7,    8,     48,    1471,  1472,  1473,
                                            2952, 2953, 8448, 12608, 24896, 33024, 65506, 65507};
    for (const bool fragment : {true, false}) {
        const auto file = dir.path() / "round_trip.pcap";
        PcapWriterOptions options;
        options.fragment = fragment;
        std::size_t expected_records = 0;
        {
            PcapWriter writer(file, options);
            for (std::size_t i = 0; i < sizes.size(); ++i) {
                const auto data = pattern(sizes[i], static_cast<std::uint32_t>(i));
                writer.write_udp(1'700'000'000'123'456'789LL + static_cast<std::int64_t>(i) * 1001,
                                 0xA9FE5C9Eu + static_cast<std::uint32_t>(i), 7000 + i % 3,
                                 0xA9FE64CCu, static_cast<std::uint16_t>(7502 + i), data.data(),
                                 data.size());
                expected_records +=
                    fragment ? std::max<std::size_t>(1, (sizes[i] + 8 + 1479) / 1480) : 1;
            }
            writer.close();
            EXPECT_EQ(writer.datagrams_written(), sizes.size());
            EXPECT_EQ(writer.records_written(), expected_records);
        }
        PcapReader reader(file);
        UdpDatagram d;
        for (std::size_t i = 0; i < sizes.size(); ++i) {
            ASSERT_TRUE(reader.next(&d)) << "datagram " << i;
            const auto data = pattern(sizes[i], static_cast<std::uint32_t>(i));
            ASSERT_EQ(d.size, sizes[i]);
            EXPECT_TRUE(std::equal(data.begin(), data.end(), d.data)) << "size " << sizes[i];
            EXPECT_EQ(d.timestamp_ns,
                      1'700'000'000'123'456'789LL + static_cast<std::int64_t>(i) * 1001);
            EXPECT_EQ(d.src_ip, 0xA9FE5C9Eu + i);
            EXPECT_EQ(d.dst_ip, 0xA9FE64CCu);
            EXPECT_EQ(d.src_port, 7000 + i % 3);
            EXPECT_EQ(d.dst_port, 7502 + i);
            EXPECT_EQ(d.reassembled, fragment && sizes[i] + 8 > 1480);
        }
        EXPECT_FALSE(reader.next(&d));
        EXPECT_EQ(reader.stats().records, expected_records);
        EXPECT_EQ(reader.stats().dropped_incomplete, 0u);
        EXPECT_EQ(reader.stats().malformed, 0u);
    }
}

TEST(PcapWriter, MicrosecondFilesTruncateTimestampsAndReadBack) {
    test::TempDir dir("pcap_writer_us");
    const auto file = dir.path() / "us.pcap";
    PcapWriterOptions options;
    options.nanosecond_timestamps = false;
    {
        PcapWriter writer(file, options);
        const std::uint8_t data[3] = {1, 2, 3};
        writer.write_udp(1'234'567'891'987'654'321LL, 1, 2, 3, 4, data, 3);
    }
    std::uint32_t magic = 0;
    const auto records = raw_records(file, &magic);
    EXPECT_EQ(magic, 0xA1B2C3D4u);
    ASSERT_EQ(records.size(), 1u);
    EXPECT_EQ(records[0].ts_frac, 987654u);
    PcapReader reader(file);
    UdpDatagram d;
    ASSERT_TRUE(reader.next(&d));
    EXPECT_EQ(d.timestamp_ns, 1'234'567'891'987'654'000LL);
}

TEST(PcapWriter, HeadersCarryValidChecksumsAndFragmentFlags) {
    test::TempDir dir("pcap_writer_sum");
    const auto file = dir.path() / "sum.pcap";
    const auto data = pattern(12608, 3);
    {
        PcapWriter writer(file);
        writer.write_udp(5, 0x0A050665, 50474, 0x0A050601, 34636, data.data(), data.size());
        writer.write_udp(6, 0x0A050665, 50474, 0x0A050601, 34636, data.data(), 333);
    }
    std::uint32_t magic = 0;
    const auto records = raw_records(file, &magic);
    EXPECT_EQ(magic, 0xA1B23C4Du);
    ASSERT_EQ(records.size(), 10u);  // 9 fragments + 1 whole
    for (std::size_t i = 0; i < records.size(); ++i) {
        const std::uint8_t* ip = records[i].frame.data() + 14;
        EXPECT_EQ(be16(records[i].frame.data() + 12), 0x0800);
        std::uint32_t sum = internet_checksum_add(0, ip, 20);
        EXPECT_EQ(internet_checksum_finish(sum), 0) << "record " << i;
        const std::uint16_t flags = be16(ip + 6);
        EXPECT_EQ((flags & 0x2000) != 0, i < 8) << "MF of record " << i;
        EXPECT_EQ((flags & 0x1FFF) * 8u, i < 9 ? i * 1480 : 0u);
        EXPECT_LE(be16(ip + 2), 1500);
    }
    // UDP checksum over the pseudo-header of the whole (unfragmented) datagram verifies to 0.
    const std::uint8_t* ip = records[9].frame.data() + 14;
    std::uint8_t pseudo[12] = {};
    std::memcpy(pseudo, ip + 12, 8);
    pseudo[9] = 17;
    pseudo[10] = ip[24];
    pseudo[11] = ip[25];
    std::uint32_t sum = internet_checksum_add(0, pseudo, 12);
    sum = internet_checksum_add(sum, ip + 20, 8 + 333);
    EXPECT_EQ(internet_checksum_finish(sum), 0);
}

TEST(PcapWriter, FragmentLayoutMatchesARealCapture) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "same_ports_legacy.pcap");
    test::TempDir dir("pcap_writer_real");
    const auto copy = dir.path() / "copy.pcap";
    {
        PcapReader reader(file);
        PcapWriter writer(copy);
        UdpDatagram d;
        while (reader.next(&d)) {
            writer.write_udp(d.timestamp_ns, d.src_ip, d.src_port, d.dst_ip, d.dst_port, d.data,
                             d.size);
        }
    }
    std::uint32_t magic = 0;
    const auto original = raw_records(file, &magic);
    const auto ours = raw_records(copy, &magic);
    ASSERT_EQ(original.size(), ours.size());
    for (std::size_t i = 0; i < ours.size(); ++i) {
        EXPECT_EQ(ours[i].caplen, original[i].caplen) << "record " << i;
        const std::uint8_t* a = original[i].frame.data() + 14;
        const std::uint8_t* b = ours[i].frame.data() + 14;
        EXPECT_EQ(be16(a + 6), be16(b + 6)) << "flags/offset of record " << i;
        // Same IP payload bytes (UDP header with the sensor's checksum, then data).
        EXPECT_TRUE(std::equal(a + 20, a + be16(a + 2), b + 20)) << "payload of record " << i;
    }
}

TEST(PcapWriter, InterleavedReorderedAndDuplicatedFragmentsReassemble) {
    test::TempDir dir("pcap_writer_mix");
    const auto file = dir.path() / "mix.pcap";
    std::mt19937 rng(42);
    constexpr int kDatagrams = 200;
    std::map<std::uint16_t, std::vector<std::uint8_t>> sent;  // by destination port
    std::uint64_t duplicates = 0;
    {
        PcapWriter writer(file);
        std::vector<std::vector<std::uint8_t>> frames, pool;
        // Fragments of up to 6 datagrams at a time are shuffled together, some duplicated.
        for (int group = 0; group < kDatagrams / 5; ++group) {
            pool.clear();
            for (int k = 0; k < 5; ++k) {
                const int n = group * 5 + k;
                const std::size_t size = std::uniform_int_distribution<std::size_t>(0, 65507)(rng);
                auto data = pattern(size, static_cast<std::uint32_t>(n));
                const auto port = static_cast<std::uint16_t>(10000 + n);
                build_udp_frames(
                    {0x7F000001u + static_cast<std::uint32_t>(k % 2), 4000, 0x7F000001u, port},
                    static_cast<std::uint16_t>(n), data.data(), data.size(), 1500, &frames);
                for (const auto& f : frames) {
                    pool.push_back(f);
                    if (rng() % 7 == 0) {
                        pool.push_back(f);  // duplicate
                        ++duplicates;
                    }
                }
                sent[port] = std::move(data);
            }
            std::shuffle(pool.begin(), pool.end(), rng);
            for (const auto& f : pool) writer.write_frame(group * 1000 + 1, f.data(), f.size());
        }
    }
    PcapReader reader(file);
    UdpDatagram d;
    std::map<std::uint16_t, int> received;
    while (reader.next(&d)) {
        ++received[d.dst_port];
        const auto it = sent.find(d.dst_port);
        ASSERT_NE(it, sent.end());
        ASSERT_EQ(d.size, it->second.size()) << "port " << d.dst_port;
        EXPECT_TRUE(std::equal(it->second.begin(), it->second.end(), d.data))
            << "port " << d.dst_port;
    }
    EXPECT_EQ(received.size(), sent.size());
    for (const auto& [port, count] : received) EXPECT_EQ(count, 1) << "port " << port;
    // A duplicate that arrives after its datagram completed starts a new partial datagram
    // that can never complete (as in Linux); those, and only those, are discarded.
    EXPECT_GT(duplicates, 0u);
    EXPECT_LE(reader.stats().discarded_fragments, duplicates);
    EXPECT_LE(reader.stats().dropped_incomplete, reader.stats().discarded_fragments);
}

TEST(PcapWriter, RejectsOversizedDatagramsAndUnwritableFiles) {
    test::TempDir dir("pcap_writer_bad");
    PcapWriter writer(dir.path() / "x.pcap");
    std::vector<std::uint8_t> big(65508);
    EXPECT_THROW(writer.write_udp(0, 1, 2, 3, 4, big.data(), big.size()), std::invalid_argument);
    EXPECT_THROW(writer.write_udp(-1, 1, 2, 3, 4, big.data(), 10), std::invalid_argument);
    try {
        PcapWriter bad("/nonexistent/dir/x.pcap");
        FAIL();
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/x.pcap"), std::string::npos);
    }
}

}  // namespace
}  // namespace lidarfuse::pcap
