#include "drivers/pcap/pcap_writer.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace lidarfuse::pcap {

namespace {

constexpr std::uint32_t kMagicMicroseconds = 0xA1B2C3D4u;
constexpr std::uint32_t kMagicNanoseconds = 0xA1B23C4Du;
constexpr std::uint32_t kSnapLenBytes = 262144;  // what tcpdump writes; > any IPv4 frame
constexpr std::uint32_t kLinkTypeEthernet = 1;

void put_le16(std::uint8_t* p, std::uint32_t v) {
    p[0] = static_cast<std::uint8_t>(v);
    p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put_le32(std::uint8_t* p, std::uint32_t v) {
    put_le16(p, v & 0xFFFFu);
    put_le16(p + 2, v >> 16);
}

}  // namespace

PcapWriter::PcapWriter(const std::filesystem::path& file, const PcapWriterOptions& options)
    : file_(file), options_(options), next_ip_id_(options.first_ip_id) {
    if (options_.fragment && options_.mtu_bytes < 68) {
        throw std::invalid_argument("pcap writer for " + file.string() + ": MTU " +
                                    std::to_string(options_.mtu_bytes) + " is below 68 bytes");
    }
    stream_ = std::fopen(file.c_str(), "wb");
    if (!stream_) {
        throw std::runtime_error("cannot create capture " + file.string() + ": " +
                                 std::strerror(errno));
    }
    std::uint8_t header[24];
    put_le32(header, options_.nanosecond_timestamps ? kMagicNanoseconds : kMagicMicroseconds);
    put_le16(header + 4, 2);  // version 2.4
    put_le16(header + 6, 4);
    put_le32(header + 8, 0);   // thiszone: timestamps are UTC
    put_le32(header + 12, 0);  // sigfigs
    put_le32(header + 16, kSnapLenBytes);
    put_le32(header + 20, kLinkTypeEthernet);
    write_bytes(header, sizeof header);
}

PcapWriter::~PcapWriter() {
    if (stream_) std::fclose(stream_);
}

void PcapWriter::write_bytes(const void* data, std::size_t size) {
    if (!stream_) throw std::runtime_error("capture " + file_.string() + " is already closed");
    if (size > 0 && std::fwrite(data, 1, size, stream_) != size) {
        throw std::runtime_error("cannot write capture " + file_.string() + ": " +
                                 std::strerror(errno));
    }
}

void PcapWriter::write_frame(std::int64_t timestamp_ns, const std::uint8_t* frame, std::size_t size,
                             std::size_t wire_bytes) {
    if (timestamp_ns < 0) {
        throw std::invalid_argument("capture " + file_.string() + ": negative timestamp");
    }
    if (size > kSnapLenBytes) {
        throw std::invalid_argument("capture " + file_.string() + ": frame of " +
                                    std::to_string(size) + " bytes exceeds the snap length");
    }
    const std::int64_t seconds = timestamp_ns / 1'000'000'000;
    const std::int64_t sub_ns = timestamp_ns % 1'000'000'000;
    std::uint8_t header[16];
    put_le32(header, static_cast<std::uint32_t>(seconds));
    put_le32(header + 4,
             static_cast<std::uint32_t>(options_.nanosecond_timestamps ? sub_ns : sub_ns / 1000));
    put_le32(header + 8, static_cast<std::uint32_t>(size));
    put_le32(header + 12, static_cast<std::uint32_t>(wire_bytes > size ? wire_bytes : size));
    write_bytes(header, sizeof header);
    write_bytes(frame, size);
    ++records_;
}

void PcapWriter::write_udp(std::int64_t timestamp_ns, std::uint32_t src_ip, std::uint16_t src_port,
                           std::uint32_t dst_ip, std::uint16_t dst_port, const std::uint8_t* data,
                           std::size_t size) {
    const UdpEndpoints endpoints{src_ip, src_port, dst_ip, dst_port};
    build_udp_frames(endpoints, next_ip_id_, data, size, options_.fragment ? options_.mtu_bytes : 0,
                     &frames_);
    for (const auto& frame : frames_) write_frame(timestamp_ns, frame.data(), frame.size());
    ++next_ip_id_;  // wraps at 65536 like a real sender
    ++datagrams_;
}

void PcapWriter::flush() {
    if (stream_ && std::fflush(stream_) != 0) {
        throw std::runtime_error("cannot write capture " + file_.string() + ": " +
                                 std::strerror(errno));
    }
}

void PcapWriter::close() {
    if (!stream_) return;
    std::FILE* stream = stream_;
    stream_ = nullptr;
    if (std::fclose(stream) != 0) {
        throw std::runtime_error("cannot close capture " + file_.string() + ": " +
                                 std::strerror(errno));
    }
}

}  // namespace lidarfuse::pcap
