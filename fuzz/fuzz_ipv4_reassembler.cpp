// libFuzzer harness: IPv4 fragments straight into the Ipv4Reassembler (the pcap harness
// reaches it too, but through libpcap and header decoding, which cost most of its time).
//
// Input (see fuzz_input.hpp): byte 0 = table size - 1 (mod 8), then per fragment
//   byte   bit 0 more-fragments, bits 1-2 source address, bits 3-4 identification,
//          bit 5 protocol UDP/other, bits 6-7 capture time step (0, 1 ms, 0.4 s, 2 s)
//   u16    fragment offset in 8-byte units (13 bits used, as on the wire)
//   record fragment payload
// Checked besides memory safety: a delivered datagram fits an IPv4 payload and covers
// the fragment that completed it, the table never holds more than its size, and the
// counters add up: every fragment is pending, part of a delivered datagram, discarded or
// a duplicate.
#include <cstddef>
#include <cstdint>

#include "drivers/pcap/ipv4_reassembler.hpp"
#include "fuzz/fuzz_input.hpp"

using namespace lidarfuse;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    fuzz::FuzzInput in(data, size);
    pcap::Ipv4ReassemblerParams params;
    params.max_entries = 1 + (in.byte() % 8);
    pcap::Ipv4Reassembler reassembler(params);
    constexpr std::int64_t kSteps[] = {0, 1'000'000, 400'000'000, 2'000'000'000};
    std::int64_t t_ns = 0;
    volatile std::uint64_t sink = 0;
    while (in.remaining() > 0) {
        const std::uint8_t flags = in.byte();
        pcap::Ipv4Fragment f;
        f.more_fragments = (flags & 1) != 0;
        f.src_ip = 0x0A000001u + ((flags >> 1) & 3);
        f.dst_ip = 0x0A0000FEu;
        f.id = static_cast<std::uint16_t>(0x1000 + ((flags >> 3) & 3));
        f.protocol = (flags & 0x20) ? 17 : 6;
        t_ns += kSteps[flags >> 6];
        f.timestamp_ns = t_ns;
        f.offset_bytes = static_cast<std::uint32_t>(in.u16() & 0x1FFF) * 8;
        if (!in.record(&f.payload, &f.size)) break;
        pcap::ReassembledDatagram out;
        if (reassembler.add(f, &out)) {
            if (out.size > pcap::Ipv4Reassembler::kMaxPayloadBytes) fuzz::invariant_failed("size");
            if (out.size < f.offset_bytes + f.size)
                fuzz::invariant_failed("misses its last fragment");
            if (out.src_ip != f.src_ip || out.protocol != f.protocol) fuzz::invariant_failed("key");
            std::uint64_t sum = 0;
            for (std::size_t i = 0; i < out.size; ++i) sum += out.payload[i];
            sink = sink + sum;
        }
        if (reassembler.pending() > params.max_entries) fuzz::invariant_failed("table overflow");
    }
    reassembler.flush();
    const auto& s = reassembler.stats();
    if (reassembler.pending() != 0) fuzz::invariant_failed("pending after flush");
    if (s.dropped_incomplete != s.timeouts + s.evictions + s.id_reuses + s.flushed) {
        fuzz::invariant_failed("dropped_incomplete != sum of its reasons");
    }
    return 0;
}
