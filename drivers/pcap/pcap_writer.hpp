#pragma once
// Writes UDP/IPv4 datagrams into a classic pcap file (link type Ethernet), as a capture on
// the receiving host's network interface would hold them.
//
// Timestamp precision: nanosecond by default (magic 0xA1B23C4D), so the simulator's packet
// times survive a round trip exactly; microsecond (magic 0xA1B2C3D4, what tcpdump writes
// by default) on request, truncating to whole microseconds. PcapReader reads both.
// Fragmentation: by default each datagram is split into IPv4 fragments at MTU 1500 exactly
// like the Ouster captures from a real network; `fragment = false` writes whole datagrams
// like a loopback capture. Byte order of the file: little-endian.
// Not on the real-time path: I/O errors throw std::runtime_error naming the file.

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "drivers/pcap/udp_frame_builder.hpp"

namespace lidarfuse::pcap {

struct PcapWriterOptions {
    bool nanosecond_timestamps = true;
    bool fragment = true;                       // split datagrams at mtu_bytes
    std::size_t mtu_bytes = kEthernetMtuBytes;  // IPv4 MTU when fragmenting
    std::uint16_t first_ip_id = 1;  // IPv4 identification of the first datagram (+1 each)
};

class PcapWriter {
public:
    // Creates (truncates) the file and writes the global header.
    PcapWriter(const std::filesystem::path& file, const PcapWriterOptions& options = {});
    ~PcapWriter();  // closes; errors there are lost, call close() to see them
    PcapWriter(const PcapWriter&) = delete;
    PcapWriter& operator=(const PcapWriter&) = delete;

    // One UDP datagram of `size` <= 65507 bytes at capture time `timestamp_ns` (ns since the
    // Unix epoch, >= 0). All its fragments get the same timestamp. Addresses in host order.
    void write_udp(std::int64_t timestamp_ns, std::uint32_t src_ip, std::uint16_t src_port,
                   std::uint32_t dst_ip, std::uint16_t dst_port, const std::uint8_t* data,
                   std::size_t size);

    // One raw Ethernet frame as a record (for tests that craft or reorder frames);
    // `wire_bytes` > size marks the record as truncated by the capture (caplen < len).
    void write_frame(std::int64_t timestamp_ns, const std::uint8_t* frame, std::size_t size,
                     std::size_t wire_bytes = 0);

    void flush();
    void close();  // flushes and closes; throws naming the file on failure

    std::uint64_t datagrams_written() const { return datagrams_; }
    std::uint64_t records_written() const { return records_; }
    const std::filesystem::path& file() const { return file_; }

private:
    void write_bytes(const void* data, std::size_t size);

    std::filesystem::path file_;
    PcapWriterOptions options_;
    std::FILE* stream_ = nullptr;
    std::uint16_t next_ip_id_;
    std::uint64_t datagrams_ = 0;
    std::uint64_t records_ = 0;
    std::vector<std::vector<std::uint8_t>> frames_;  // reused between datagrams
};

}  // namespace lidarfuse::pcap
