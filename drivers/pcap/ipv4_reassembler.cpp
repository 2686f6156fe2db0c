#include "drivers/pcap/ipv4_reassembler.hpp"

#include <algorithm>
#include <array>
#include <cstring>

namespace lidarfuse::pcap {

namespace {
constexpr std::size_t kBufferBytes = 65536;
constexpr std::size_t kBlockBytes = 8;  // fragment offsets count in 8-byte units
constexpr std::size_t kBlocks = (Ipv4Reassembler::kMaxPayloadBytes + kBlockBytes - 1) / kBlockBytes;
constexpr std::size_t kBitmapWords = (kBlocks + 63) / 64;
}  // namespace

struct Ipv4Reassembler::Entry {
    bool in_use = false;
    std::int64_t first_seen_ns = 0;
    std::uint32_t src_ip = 0;
    std::uint32_t dst_ip = 0;
    std::uint16_t id = 0;
    std::uint8_t protocol = 0;
    std::uint8_t* data = nullptr;  // kBufferBytes owned by Ipv4Reassembler::buffers_
    std::array<std::uint64_t, kBitmapWords> present{};  // one bit per 8-byte block
    std::size_t blocks_present = 0;
    std::size_t max_end = 0;  // highest byte end seen
    bool end_known = false;   // the final fragment (MF = 0) has arrived
    std::size_t end = 0;      // total payload bytes, when end_known
    std::uint64_t fragment_count = 0;

    bool block(std::size_t b) const { return (present[b / 64] >> (b % 64)) & 1u; }
    bool matches(const Ipv4Fragment& f) const {
        return in_use && src_ip == f.src_ip && dst_ip == f.dst_ip && id == f.id &&
               protocol == f.protocol;
    }
};

Ipv4Reassembler::Ipv4Reassembler(const Ipv4ReassemblerParams& params)
    : params_(params),
      entries_(std::max<std::size_t>(params.max_entries, 1)),
      buffers_(new std::uint8_t[entries_.size() * kBufferBytes]) {
    for (std::size_t i = 0; i < entries_.size(); ++i)
        entries_[i].data = &buffers_[i * kBufferBytes];
}

Ipv4Reassembler::~Ipv4Reassembler() = default;

std::size_t Ipv4Reassembler::pending() const {
    return static_cast<std::size_t>(
        std::count_if(entries_.begin(), entries_.end(), [](const Entry& e) { return e.in_use; }));
}

void Ipv4Reassembler::release(Entry* entry) {
    entry->in_use = false;
    entry->present.fill(0);
    entry->blocks_present = 0;
    entry->max_end = 0;
    entry->end_known = false;
    entry->end = 0;
    entry->fragment_count = 0;
}

void Ipv4Reassembler::expire(std::int64_t now_ns) {
    for (auto& e : entries_) {
        if (!e.in_use) continue;
        const std::int64_t age_ns = now_ns - e.first_seen_ns;
        // Capture time may also run backwards (merged captures): treat both ways alike.
        if (age_ns > params_.timeout_ns || -age_ns > params_.timeout_ns) {
            ++stats_.timeouts;
            ++stats_.dropped_incomplete;
            stats_.discarded_fragments += e.fragment_count;
            release(&e);
        }
    }
}

Ipv4Reassembler::Entry* Ipv4Reassembler::find_or_claim(const Ipv4Fragment& f) {
    Entry* free_entry = nullptr;
    Entry* oldest = nullptr;
    for (auto& e : entries_) {
        if (e.matches(f)) return &e;
        if (!e.in_use) {
            if (!free_entry) free_entry = &e;
        } else if (!oldest || e.first_seen_ns < oldest->first_seen_ns) {
            oldest = &e;
        }
    }
    Entry* slot = free_entry;
    if (!slot) {
        ++stats_.evictions;
        ++stats_.dropped_incomplete;
        stats_.discarded_fragments += oldest->fragment_count;
        release(oldest);
        slot = oldest;
    }
    slot->in_use = true;
    slot->first_seen_ns = f.timestamp_ns;
    slot->src_ip = f.src_ip;
    slot->dst_ip = f.dst_ip;
    slot->id = f.id;
    slot->protocol = f.protocol;
    return slot;
}

// True when the fragment cannot belong to the partial datagram in `entry`: a different end,
// data past the known end, or bytes that differ from blocks already held. Sets
// *all_present when every block it covers is already held (a duplicate).
bool Ipv4Reassembler::conflicts(const Entry& entry, const Ipv4Fragment& f, bool* all_present) {
    const std::size_t begin = f.offset_bytes;
    const std::size_t end = begin + f.size;
    *all_present = false;
    if (!f.more_fragments) {
        if (entry.end_known && entry.end != end) return true;
        if (end < entry.max_end) return true;
    } else if (entry.end_known && end > entry.end) {
        return true;
    }
    bool all = true;
    for (std::size_t b = begin / kBlockBytes; b * kBlockBytes < end; ++b) {
        if (!entry.block(b)) {
            all = false;
            continue;
        }
        const std::size_t lo = std::max(b * kBlockBytes, begin);
        std::size_t hi = std::min(b * kBlockBytes + kBlockBytes, end);
        hi = std::min(hi, entry.max_end);  // a final block may be held only partly
        if (hi > lo && std::memcmp(entry.data + lo, f.payload + (lo - begin), hi - lo) != 0) {
            return true;
        }
    }
    *all_present = all;
    return false;
}

void Ipv4Reassembler::store(Entry* entry, const Ipv4Fragment& f) {
    const std::size_t begin = f.offset_bytes;
    const std::size_t end = begin + f.size;
    if (f.size > 0) std::memcpy(entry->data + begin, f.payload, f.size);
    for (std::size_t b = begin / kBlockBytes; b * kBlockBytes < end; ++b) {
        const std::uint64_t bit = std::uint64_t{1} << (b % 64);
        if (!(entry->present[b / 64] & bit)) {
            entry->present[b / 64] |= bit;
            ++entry->blocks_present;
        }
    }
    entry->max_end = std::max(entry->max_end, end);
    if (!f.more_fragments) {
        entry->end_known = true;
        entry->end = end;
    }
    ++entry->fragment_count;
}

bool Ipv4Reassembler::add(const Ipv4Fragment& f, ReassembledDatagram* out) {
    ++stats_.fragments;
    expire(f.timestamp_ns);

    const std::size_t end = static_cast<std::size_t>(f.offset_bytes) + f.size;
    const bool bad_length = f.more_fragments && (f.size == 0 || f.size % kBlockBytes != 0);
    if (bad_length || f.offset_bytes % kBlockBytes != 0 || end > kMaxPayloadBytes ||
        (f.size > 0 && f.payload == nullptr)) {
        ++stats_.malformed_fragments;
        ++stats_.discarded_fragments;
        return false;
    }

    Entry* entry = find_or_claim(f);
    if (entry->fragment_count > 0) {
        bool duplicate = false;
        if (conflicts(*entry, f, &duplicate)) {
            // The identification was reused: what we hold belongs to an older datagram.
            ++stats_.id_reuses;
            ++stats_.dropped_incomplete;
            stats_.discarded_fragments += entry->fragment_count;
            release(entry);
            entry = find_or_claim(f);
        } else if (duplicate) {
            ++stats_.duplicate_fragments;
            ++entry->fragment_count;
            return false;
        }
    }
    store(entry, f);

    if (!entry->end_known ||
        entry->blocks_present != (entry->end + kBlockBytes - 1) / kBlockBytes) {
        return false;
    }
    out->timestamp_ns = f.timestamp_ns;
    out->src_ip = entry->src_ip;
    out->dst_ip = entry->dst_ip;
    out->protocol = entry->protocol;
    out->payload = entry->data;
    out->size = entry->end;
    ++stats_.reassembled;
    release(entry);  // the buffer keeps its bytes until the slot is claimed again
    return true;
}

void Ipv4Reassembler::flush() {
    for (auto& e : entries_) {
        if (!e.in_use) continue;
        ++stats_.flushed;
        ++stats_.dropped_incomplete;
        stats_.discarded_fragments += e.fragment_count;
        release(&e);
    }
}

}  // namespace lidarfuse::pcap
