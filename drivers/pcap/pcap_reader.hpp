#pragma once
// Reads the UDP/IPv4 datagrams of a capture file (classic pcap or pcapng, micro- or
// nanosecond timestamps) through libpcap, reassembling IPv4 fragments.
//
// Link types: Ethernet (with 802.1Q/QinQ tags), Linux cooked SLL/SLL2, raw IPv4, BSD
// loopback. Everything else in the file (ARP, IPv6, TCP, ...) is skipped and counted. A
// file that ends in the middle of a record delivers everything before the cut and then
// reports it in stats().cut_off and warning(); it is not an exception.
//
// Steady state allocates nothing: whole datagrams point into libpcap's record buffer,
// reassembled ones into the reassembler's preallocated slots. Not thread-safe.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "drivers/pcap/ipv4_reassembler.hpp"
#include "drivers/pcap/udp_datagram.hpp"

namespace lidarfuse::pcap {

struct PcapReaderParams {
    Ipv4ReassemblerParams reassembly;
};

struct PcapReaderStats {
    std::uint64_t records = 0;              // capture records read
    std::uint64_t bytes_read = 0;           // of the file, about (progress: against its size)
    std::uint64_t udp_datagrams = 0;        // datagrams delivered by next()
    std::uint64_t non_ipv4 = 0;             // records skipped: not IPv4 (ARP, IPv6, LLC, ...)
    std::uint64_t non_udp = 0;              // records skipped: IPv4 but not UDP
    std::uint64_t malformed = 0;            // records skipped: bad IPv4/UDP header or lengths
    std::uint64_t truncated_records = 0;    // records skipped: captured length < wire length
    std::uint64_t fragments = 0;            // UDP fragments handed to the reassembler
    std::uint64_t reassembled = 0;          // datagrams completed from fragments
    std::uint64_t dropped_incomplete = 0;   // partial datagrams discarded (time-out, full
                                            // table, identification reuse, end of file)
    std::uint64_t discarded_fragments = 0;  // fragments that never became a datagram
    std::uint64_t cut_off = 0;              // 1 when the file ends in the middle of a record
    std::uint64_t read_errors = 0;          // 1 when libpcap reported another read error

    PcapReaderStats& operator+=(const PcapReaderStats& o);  // several files as one capture
};

class PcapReader {
public:
    // Throws std::runtime_error naming the file when it cannot be opened, is not a
    // capture, or has a link type this reader cannot decode.
    explicit PcapReader(const std::filesystem::path& file, const PcapReaderParams& params = {});
    ~PcapReader();
    PcapReader(const PcapReader&) = delete;
    PcapReader& operator=(const PcapReader&) = delete;

    // Next UDP datagram in capture order (a reassembled one when its last fragment arrives).
    // False at the end of the file or at the first read error. `out->data` stays valid until
    // the next call.
    bool next(UdpDatagram* out);

    const PcapReaderStats& stats() const { return stats_; }
    // Empty, or why reading stopped early (names the file and the libpcap message).
    const std::string& warning() const { return warning_; }
    int link_type() const { return link_type_; }  // DLT_* value
    const std::filesystem::path& file() const { return file_; }

private:
    void finish();
    void sync_reassembly_stats();
    void stop_after_read_error();
    // One complete record (link-layer frame of `size` bytes): true with *out set when it holds
    // a whole UDP datagram, reassembled from its fragments if need be.
    bool decode_record(const std::uint8_t* frame, std::size_t size, std::int64_t timestamp_ns,
                       UdpDatagram* out);

    std::filesystem::path file_;
    struct PcapHandle;
    std::unique_ptr<PcapHandle> handle_;
    int link_type_ = 0;
    Ipv4Reassembler reassembler_;
    PcapReaderStats stats_;
    std::string warning_;
    bool finished_ = false;
};

// The files of a capture: `path` itself when it is a file; for a folder (a recording of
// lidarfused's output.record), its *.pcap files in name order, which is the order they were
// written. Throws std::runtime_error naming the path when it is neither, or a folder without any.
std::vector<std::filesystem::path> capture_files(const std::filesystem::path& path);

}  // namespace lidarfuse::pcap
