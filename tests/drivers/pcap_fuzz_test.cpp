// Randomised robustness corpus (seeded): mutated fragments, mutated capture files and random
// cuts must never crash (run under ASan/UBSan in the sanitizer build), and the reader's
// outputs stay within their documented bounds.
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <vector>

#include "drivers/pcap/ipv4_reassembler.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "drivers/pcap/pcap_writer.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::pcap {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes read_file(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void write_file(const std::filesystem::path& file, const Bytes& b, std::size_t size) {
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(size));
}

// Reads everything; checks bounds that hold for any input.
void read_everything(const std::filesystem::path& file, std::uint64_t max_records) {
    try {
        PcapReader reader(file);
        UdpDatagram d;
        std::uint64_t n = 0;
        std::uint64_t checksum = 0;
        while (reader.next(&d)) {
            ASSERT_LE(d.size, kMaxUdpPayloadBytes);
            for (std::size_t i = 0; i < d.size; i += 97) checksum += d.data[i];  // touch the bytes
            ++n;
        }
        const auto& s = reader.stats();
        EXPECT_EQ(s.udp_datagrams, n);
        EXPECT_LE(s.records, max_records);
        EXPECT_LE(n, s.records);
        EXPECT_LE(s.reassembled, s.fragments);
        (void)checksum;
    } catch (const std::runtime_error& e) {
        // A mutated global header may be rejected; the message must name the file.
        EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
}

TEST(PcapFuzz, RandomFragmentsIntoTheReassembler) {
    std::mt19937 rng(2024);
    Bytes pool(70000);
    for (auto& b : pool)
        b = static_cast<std::uint8_t>(rng() & 3);  // few values: overlaps agree often
    Ipv4ReassemblerParams params;
    params.max_entries = 4;
    params.timeout_ns = 50;
    Ipv4Reassembler r(params);
    ReassembledDatagram out;
    std::uint64_t completed = 0;
    for (int i = 0; i < 200000; ++i) {
        Ipv4Fragment f;
        f.timestamp_ns =
            i / 3 + static_cast<std::int64_t>(rng() % 20) - 10;  // jitter, also backwards
        f.src_ip = rng() % 3;
        f.dst_ip = 1;
        f.id = static_cast<std::uint16_t>(rng() % 4);
        f.protocol = 17;
        f.offset_bytes =
            static_cast<std::uint32_t>(rng() % 8 == 0 ? rng() % 65536 : (rng() % 12) * 8);
        f.more_fragments = rng() % 3 != 0;
        f.size = rng() % 4 == 0 ? rng() % 65600 : (rng() % 3) * 8 + rng() % 2;
        if (f.size > 65600) f.size = 65600;
        f.payload = pool.data() + (rng() % (pool.size() - f.size));
        if (r.add(f, &out)) {
            ASSERT_LE(out.size, Ipv4Reassembler::kMaxPayloadBytes);
            if (out.size > 0) {
                ASSERT_NE(out.payload, nullptr);
            }
            ++completed;
        }
        ASSERT_LE(r.pending(), params.max_entries);
    }
    r.flush();
    const auto& s = r.stats();
    EXPECT_EQ(s.reassembled, completed);
    EXPECT_GT(completed, 0u);
    EXPECT_GT(s.id_reuses, 0u);
    EXPECT_GT(s.malformed_fragments, 0u);
    EXPECT_EQ(s.dropped_incomplete, s.timeouts + s.evictions + s.id_reuses + s.flushed);
    EXPECT_EQ(r.pending(), 0u);
}

TEST(PcapFuzz, MutatedFragmentHeadersInACapture) {
    test::TempDir dir("pcap_fuzz");
    const auto clean = dir.path() / "clean.pcap";
    std::mt19937 rng(77);
    {
        PcapWriter writer(clean);
        Bytes data(24896);
        for (int i = 0; i < 40; ++i) {
            for (auto& b : data) b = static_cast<std::uint8_t>(rng());
            const std::size_t size = (i % 4 == 0) ? 48 : (i % 3 == 0 ? 24896 : 12608);
            writer.write_udp(1000 * i, 0xA9FE0001u + i % 2, 7502, 0xA9FE0064u, 7502, data.data(),
                             size);
        }
    }
    const Bytes original = read_file(clean);
    // Record offsets, so that mutations can aim at IPv4/UDP headers.
    std::vector<std::size_t> frames;
    for (std::size_t off = 24; off + 16 <= original.size();) {
        const std::uint32_t caplen = original[off + 8] | original[off + 9] << 8 |
                                     original[off + 10] << 16 |
                                     std::uint32_t(original[off + 11]) << 24;
        frames.push_back(off + 16);
        off += 16 + caplen;
    }
    const auto mutated = dir.path() / "mutated.pcap";
    for (int trial = 0; trial < 300; ++trial) {
        Bytes b = original;
        const int mutations = 1 + static_cast<int>(rng() % 12);
        for (int m = 0; m < mutations; ++m) {
            const std::size_t frame = frames[rng() % frames.size()];
            switch (rng() % 4) {
                case 0:  // IPv4 header byte (ihl, length, id, flags/offset, protocol)
                    b[frame + 14 + rng() % 20] = static_cast<std::uint8_t>(rng());
                    break;
                case 1:  // flags/offset field only
                    b[frame + 14 + 6 + rng() % 2] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
                    break;
                case 2:  // UDP header (first fragment) or payload start
                    b[frame + 34 + rng() % 8] = static_cast<std::uint8_t>(rng());
                    break;
                default:  // anywhere after the global header, record headers included
                    b[24 + rng() % (b.size() - 24)] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
                    break;
            }
        }
        write_file(mutated, b, b.size());
        read_everything(mutated, frames.size() + 1);
        if (HasFatalFailure()) return;
    }
}

TEST(PcapFuzz, RandomCutsOfRealCaptures) {
    std::mt19937 rng(5);
    test::TempDir dir("pcap_cuts");
    for (const char* name :
         {"same_ports_legacy.pcap", "duplicate_id.pcap", "OS-1-64_1024x10_fw20.pcap"}) {
        const auto file = test::ouster_file(name);
        if (!file) GTEST_SKIP() << name << " not found";
        const Bytes b = read_file(*file);
        for (int trial = 0; trial < 40; ++trial) {
            const std::size_t cut = rng() % b.size();
            write_file(dir.path() / "cut.pcap", b, cut);
            read_everything(dir.path() / "cut.pcap", 100);
            if (HasFatalFailure()) return;
        }
    }
}

}  // namespace
}  // namespace lidarfuse::pcap
