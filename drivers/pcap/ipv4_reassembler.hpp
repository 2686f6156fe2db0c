#pragma once
// IPv4 fragment reassembly (RFC 791) for capture files, with a bounded table.
//
// Fragments are keyed by (source, destination, identification, protocol). Every table slot
// owns a preallocated 64 KiB buffer and a coverage bitmap in 8-byte blocks, so adding a
// fragment never allocates. Rules, chosen to behave like a Linux receiver on the captures
// we see from Ouster sensors (fragments of one datagram arrive within a millisecond):
//  - a datagram is complete once the last fragment (MF = 0) is known and every 8-byte block
//    before its end has arrived; the completing fragment's timestamp is the datagram's;
//  - an exact or identical-content overlap (a retransmitted duplicate) is ignored;
//  - a fragment whose bytes conflict with data already held means the identification was
//    reused by a new datagram: the old partial datagram is discarded (counted as stray)
//    and a new one is started from this fragment;
//  - partial datagrams older than `timeout_ns` of capture time are discarded, as are the
//    oldest ones when the table is full, and whatever is left at flush();
//  - fragments that are malformed (a non-final fragment whose length is not a multiple of
//    8 or is empty, data past 65515 bytes) are discarded and counted.
// Not thread-safe: one reassembler per reader.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace lidarfuse::pcap {

struct Ipv4ReassemblerParams {
    std::size_t max_entries = 16;  // partial datagrams held at once (each costs ~65 KiB)
    // Capture-time age after which a partial datagram is dropped. Shorter than Linux's
    // 30 s ipfrag_time so that a 16-bit identification reused later cannot merge datagrams.
    std::int64_t timeout_ns = 1'000'000'000;
};

struct Ipv4ReassemblerStats {
    std::uint64_t fragments = 0;    // fragments offered to add()
    std::uint64_t reassembled = 0;  // datagrams completed
    // Partial datagrams discarded, for any of the reasons below.
    std::uint64_t dropped_incomplete = 0;
    std::uint64_t timeouts = 0;   // ... older than timeout_ns
    std::uint64_t evictions = 0;  // ... oldest in a full table
    std::uint64_t id_reuses = 0;  // ... conflicting with a newer fragment of the same key
    std::uint64_t flushed = 0;    // ... left over at flush()
    // Fragments that never became part of a delivered datagram: those of the discarded
    // partial datagrams above plus malformed ones (stray fragments).
    std::uint64_t discarded_fragments = 0;
    std::uint64_t malformed_fragments = 0;  // bad length/offset, past 65515 bytes
    std::uint64_t duplicate_fragments = 0;  // entirely covered by identical data, ignored
};

// One fragment as found in an IPv4 packet: payload excludes the IPv4 header.
struct Ipv4Fragment {
    std::int64_t timestamp_ns = 0;
    std::uint32_t src_ip = 0;  // host byte order
    std::uint32_t dst_ip = 0;
    std::uint16_t id = 0;
    std::uint8_t protocol = 0;
    std::uint32_t offset_bytes = 0;  // fragment offset field x 8
    bool more_fragments = false;
    const std::uint8_t* payload = nullptr;
    std::size_t size = 0;
};

struct ReassembledDatagram {
    std::int64_t timestamp_ns = 0;
    std::uint32_t src_ip = 0;
    std::uint32_t dst_ip = 0;
    std::uint8_t protocol = 0;
    const std::uint8_t* payload = nullptr;  // IP payload; valid until the next add()/flush()
    std::size_t size = 0;
};

class Ipv4Reassembler {
public:
    // Largest IP payload a datagram can carry: 65535 total length minus a 20-byte header.
    static constexpr std::size_t kMaxPayloadBytes = 65535 - 20;

    explicit Ipv4Reassembler(const Ipv4ReassemblerParams& params = {});
    ~Ipv4Reassembler();
    Ipv4Reassembler(const Ipv4Reassembler&) = delete;
    Ipv4Reassembler& operator=(const Ipv4Reassembler&) = delete;

    // Adds one fragment; returns true and fills `out` when it completed a datagram.
    bool add(const Ipv4Fragment& fragment, ReassembledDatagram* out);

    // Discards every partial datagram (end of input), counting them as dropped_incomplete.
    void flush();

    std::size_t pending() const;
    const Ipv4ReassemblerStats& stats() const { return stats_; }

private:
    struct Entry;

    Entry* find_or_claim(const Ipv4Fragment& fragment);
    void release(Entry* entry);
    void expire(std::int64_t now_ns);
    static bool conflicts(const Entry& entry, const Ipv4Fragment& fragment, bool* all_present);
    static void store(Entry* entry, const Ipv4Fragment& fragment);

    Ipv4ReassemblerParams params_;
    std::vector<Entry> entries_;
    std::unique_ptr<std::uint8_t[]> buffers_;  // max_entries x kBufferBytes, allocated once
    Ipv4ReassemblerStats stats_;
};

}  // namespace lidarfuse::pcap
