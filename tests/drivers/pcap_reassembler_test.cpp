// Ipv4Reassembler rules: order independence, overlaps, identification reuse, bounded table,
// capture-time time-out, malformed fragments, the 65,515-byte limit.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "drivers/pcap/ipv4_reassembler.hpp"

namespace lidarfuse::pcap {
namespace {

std::vector<std::uint8_t> bytes(std::size_t size, std::uint8_t seed) {
    std::vector<std::uint8_t> out(size);
    for (std::size_t i = 0; i < size; ++i) out[i] = static_cast<std::uint8_t>(seed + i * 13);
    return out;
}

Ipv4Fragment piece(const std::vector<std::uint8_t>& whole, std::size_t begin, std::size_t end,
                   std::int64_t t_ns = 0, std::uint16_t id = 9, std::uint32_t src = 1) {
    Ipv4Fragment f;
    f.timestamp_ns = t_ns;
    f.src_ip = src;
    f.dst_ip = 2;
    f.id = id;
    f.protocol = 17;
    f.offset_bytes = static_cast<std::uint32_t>(begin);
    f.more_fragments = end < whole.size();
    f.payload = whole.data() + begin;
    f.size = end - begin;
    return f;
}

TEST(Ipv4Reassembler, AnyOrderCompletesExactlyOnce) {
    const auto whole = bytes(5000, 3);
    std::vector<std::pair<std::size_t, std::size_t>> spans = {
        {0, 1480}, {1480, 2960}, {2960, 4440}, {4440, 5000}};
    std::mt19937 rng(1);
    for (int trial = 0; trial < 24; ++trial) {
        std::shuffle(spans.begin(), spans.end(), rng);
        Ipv4Reassembler r;
        ReassembledDatagram out;
        for (std::size_t i = 0; i < spans.size(); ++i) {
            const bool done = r.add(
                piece(whole, spans[i].first, spans[i].second, static_cast<std::int64_t>(i)), &out);
            ASSERT_EQ(done, i + 1 == spans.size());
        }
        ASSERT_EQ(out.size, whole.size());
        EXPECT_TRUE(std::equal(whole.begin(), whole.end(), out.payload));
        EXPECT_EQ(out.timestamp_ns, 3);
        EXPECT_EQ(r.pending(), 0u);
        EXPECT_EQ(r.stats().reassembled, 1u);
    }
}

TEST(Ipv4Reassembler, IdenticalOverlapsAndDuplicatesAreIgnored) {
    const auto whole = bytes(3003, 5);
    Ipv4Reassembler r;
    ReassembledDatagram out;
    EXPECT_FALSE(r.add(piece(whole, 0, 1600), &out));
    EXPECT_FALSE(r.add(piece(whole, 0, 1600), &out));    // exact duplicate
    EXPECT_FALSE(r.add(piece(whole, 800, 2400), &out));  // overlaps, same bytes
    EXPECT_FALSE(r.add(piece(whole, 800, 1200), &out));  // inside, same bytes
    EXPECT_TRUE(r.add(piece(whole, 2400, 3003), &out));
    ASSERT_EQ(out.size, whole.size());
    EXPECT_TRUE(std::equal(whole.begin(), whole.end(), out.payload));
    EXPECT_EQ(r.stats().duplicate_fragments, 2u);
    EXPECT_EQ(r.stats().dropped_incomplete, 0u);
}

TEST(Ipv4Reassembler, ConflictingBytesMeanTheIdWasReused) {
    const auto old_datagram = bytes(3000, 1);
    const auto new_datagram = bytes(3000, 2);
    Ipv4Reassembler r;
    ReassembledDatagram out;
    EXPECT_FALSE(r.add(piece(old_datagram, 0, 1480), &out));  // stray from an older datagram
    EXPECT_FALSE(r.add(piece(new_datagram, 0, 1480), &out));
    EXPECT_FALSE(r.add(piece(new_datagram, 1480, 2960), &out));
    EXPECT_TRUE(r.add(piece(new_datagram, 2960, 3000), &out));
    ASSERT_EQ(out.size, new_datagram.size());
    EXPECT_TRUE(std::equal(new_datagram.begin(), new_datagram.end(), out.payload));
    EXPECT_EQ(r.stats().id_reuses, 1u);
    EXPECT_EQ(r.stats().dropped_incomplete, 1u);
    EXPECT_EQ(r.stats().discarded_fragments, 1u);
}

TEST(Ipv4Reassembler, DifferentEndsConflict) {
    const auto a = bytes(3000, 1);
    const auto b = bytes(2000, 1);  // same leading bytes, shorter
    Ipv4Reassembler r;
    ReassembledDatagram out;
    EXPECT_FALSE(r.add(piece(a, 2960, 3000), &out));
    EXPECT_FALSE(r.add(piece(b, 1480, 2000), &out));  // a second, different end
    EXPECT_TRUE(r.add(piece(b, 0, 1480), &out));
    EXPECT_EQ(out.size, 2000u);
    EXPECT_EQ(r.stats().id_reuses, 1u);
}

TEST(Ipv4Reassembler, KeysSeparateSourcesAndIds) {
    const auto a = bytes(3000, 1), b = bytes(3000, 2);
    Ipv4Reassembler r;
    ReassembledDatagram out;
    EXPECT_FALSE(r.add(piece(a, 0, 1480, 0, 5, 1), &out));
    EXPECT_FALSE(r.add(piece(b, 0, 1480, 0, 5, 2), &out));  // other source, same id
    EXPECT_FALSE(r.add(piece(b, 1480, 2960, 0, 5, 2), &out));
    EXPECT_FALSE(r.add(piece(a, 1480, 2960, 0, 5, 1), &out));
    ASSERT_TRUE(r.add(piece(a, 2960, 3000, 0, 5, 1), &out));
    EXPECT_EQ(out.src_ip, 1u);
    EXPECT_TRUE(std::equal(a.begin(), a.end(), out.payload));
    ASSERT_TRUE(r.add(piece(b, 2960, 3000, 0, 5, 2), &out));
    EXPECT_EQ(out.src_ip, 2u);
    EXPECT_TRUE(std::equal(b.begin(), b.end(), out.payload));
    EXPECT_EQ(r.stats().id_reuses, 0u);
}

TEST(Ipv4Reassembler, FullTableEvictsTheOldestPartialDatagram) {
    Ipv4ReassemblerParams params;
    params.max_entries = 2;
    Ipv4Reassembler r(params);
    const auto whole = bytes(3000, 1);
    ReassembledDatagram out;
    EXPECT_FALSE(r.add(piece(whole, 0, 1480, 10, 1), &out));
    EXPECT_FALSE(r.add(piece(whole, 0, 1480, 20, 2), &out));
    EXPECT_FALSE(r.add(piece(whole, 0, 1480, 30, 3), &out));  // evicts id 1
    EXPECT_EQ(r.pending(), 2u);
    EXPECT_EQ(r.stats().evictions, 1u);
    EXPECT_FALSE(r.add(piece(whole, 1480, 2960, 40, 1), &out));  // id 1 starts over, evicts 2
    EXPECT_FALSE(r.add(piece(whole, 2960, 3000, 50, 1), &out));  // never completes
    EXPECT_FALSE(r.add(piece(whole, 1480, 2960, 60, 3), &out));
    EXPECT_TRUE(r.add(piece(whole, 2960, 3000, 70, 3), &out));
    EXPECT_EQ(r.stats().evictions, 2u);
    r.flush();
    EXPECT_EQ(r.stats().flushed, 1u);
    EXPECT_EQ(r.stats().dropped_incomplete, 3u);
    EXPECT_EQ(r.pending(), 0u);
}

TEST(Ipv4Reassembler, PartialDatagramsTimeOutInCaptureTime) {
    Ipv4ReassemblerParams params;
    params.timeout_ns = 1000;
    Ipv4Reassembler r(params);
    const auto whole = bytes(3000, 1);
    ReassembledDatagram out;
    EXPECT_FALSE(r.add(piece(whole, 0, 1480, 0), &out));
    EXPECT_FALSE(r.add(piece(whole, 1480, 2960, 500), &out));
    EXPECT_FALSE(r.add(piece(whole, 2960, 3000, 1001), &out));  // the first two expired
    EXPECT_EQ(r.stats().timeouts, 1u);
    EXPECT_EQ(r.stats().discarded_fragments, 2u);
    EXPECT_FALSE(r.add(piece(whole, 0, 1480, 1500), &out));
    EXPECT_TRUE(r.add(piece(whole, 1480, 2960, 1600), &out));  // within 1000 ns of 1001
    EXPECT_EQ(out.size, 3000u);
}

TEST(Ipv4Reassembler, MalformedFragmentsAreDiscardedAndCounted) {
    const auto whole = bytes(70000, 1);
    Ipv4Reassembler r;
    ReassembledDatagram out;
    EXPECT_FALSE(r.add(piece(whole, 0, 1001), &out));  // non-final, not a multiple of 8
    Ipv4Fragment empty = piece(whole, 0, 0);
    empty.more_fragments = true;
    EXPECT_FALSE(r.add(empty, &out));
    EXPECT_FALSE(r.add(piece(whole, 65000, 65520), &out));  // past 65,515 bytes
    Ipv4Fragment odd = piece(whole, 8, 16);
    odd.offset_bytes = 12;  // offsets come in 8-byte units
    EXPECT_FALSE(r.add(odd, &out));
    EXPECT_EQ(r.stats().malformed_fragments, 4u);
    EXPECT_EQ(r.pending(), 0u);
}

TEST(Ipv4Reassembler, LargestDatagramReassembles) {
    std::vector<std::uint8_t> whole = bytes(Ipv4Reassembler::kMaxPayloadBytes, 9);
    Ipv4Reassembler r;
    ReassembledDatagram out;
    std::size_t begin = 0;
    bool done = false;
    while (begin < whole.size()) {
        const std::size_t end = std::min(begin + 1480, whole.size());
        done = r.add(piece(whole, begin, end), &out);
        begin = end;
    }
    ASSERT_TRUE(done);
    ASSERT_EQ(out.size, whole.size());
    EXPECT_TRUE(std::equal(whole.begin(), whole.end(), out.payload));
}

}  // namespace
}  // namespace lidarfuse::pcap
