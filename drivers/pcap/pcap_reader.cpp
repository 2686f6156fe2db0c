#include "drivers/pcap/pcap_reader.hpp"

#include <pcap/pcap.h>

#include <algorithm>
#include <stdexcept>

#include "drivers/pcap/frame_decoder.hpp"

namespace lidarfuse::pcap {

struct PcapReader::PcapHandle {
    pcap_t* pcap = nullptr;
    ~PcapHandle() {
        if (pcap) pcap_close(pcap);
    }
};

PcapReader::PcapReader(const std::filesystem::path& file, const PcapReaderParams& params)
    : file_(file), handle_(std::make_unique<PcapHandle>()), reassembler_(params.reassembly) {
    char errbuf[PCAP_ERRBUF_SIZE] = {};
    // Nanosecond precision: libpcap scales microsecond files up, so both read alike.
    handle_->pcap =
        pcap_open_offline_with_tstamp_precision(file.c_str(), PCAP_TSTAMP_PRECISION_NANO, errbuf);
    if (!handle_->pcap) {
        throw std::runtime_error("cannot read capture " + file.string() + ": " + errbuf);
    }
    link_type_ = pcap_datalink(handle_->pcap);
    if (!is_supported_link_type(link_type_)) {
        const char* name = pcap_datalink_val_to_name(link_type_);
        throw std::runtime_error("capture " + file.string() + " has link type " +
                                 std::to_string(link_type_) + " (" + (name ? name : "unknown") +
                                 "); supported: Ethernet, Linux SLL/SLL2, raw IPv4, loopback");
    }
}

PcapReader::~PcapReader() = default;

void PcapReader::sync_reassembly_stats() {
    const auto& r = reassembler_.stats();
    stats_.fragments = r.fragments;
    stats_.reassembled = r.reassembled;
    stats_.dropped_incomplete = r.dropped_incomplete;
    stats_.discarded_fragments = r.discarded_fragments;
}

void PcapReader::finish() {
    finished_ = true;
    reassembler_.flush();
    sync_reassembly_stats();
}

namespace {

// Whether a decoded frame is an IPv4 UDP packet (or fragment); counts the ones that are not.
bool is_ipv4_udp(FrameKind kind, const Ipv4Packet& ip, PcapReaderStats* stats) {
    switch (kind) {
        case FrameKind::kIpv4:
            break;
        case FrameKind::kNotIpv4:
        case FrameKind::kUnsupportedLink:
            ++stats->non_ipv4;
            return false;
        case FrameKind::kMalformed:
            ++stats->malformed;
            return false;
    }
    if (ip.protocol != kIpProtocolUdp) {
        ++stats->non_udp;
        return false;
    }
    return true;
}

Ipv4Fragment to_fragment(const Ipv4Packet& ip, std::int64_t timestamp_ns) {
    Ipv4Fragment fragment;
    fragment.timestamp_ns = timestamp_ns;
    fragment.src_ip = ip.src_ip;
    fragment.dst_ip = ip.dst_ip;
    fragment.id = ip.id;
    fragment.protocol = ip.protocol;
    fragment.offset_bytes = ip.offset_bytes;
    fragment.more_fragments = ip.more_fragments;
    fragment.payload = ip.payload;
    fragment.size = ip.payload_size;
    return fragment;
}

}  // namespace

// libpcap failed to read a record: a short record (header or data) it reports as "truncated
// dump file" means the file is cut off; anything else is a read error. Either ends the file.
void PcapReader::stop_after_read_error() {
    const std::string message = pcap_geterr(handle_->pcap);
    if (message.find("truncated") != std::string::npos) {
        stats_.cut_off = 1;
        warning_ = "capture " + file_.string() + " is cut off after record " +
                   std::to_string(stats_.records) + ": " + message;
    } else {
        stats_.read_errors = 1;
        warning_ = "capture " + file_.string() + ": read error after record " +
                   std::to_string(stats_.records) + ": " + message;
    }
    finish();
}

bool PcapReader::decode_record(const std::uint8_t* frame, std::size_t size,
                               std::int64_t timestamp_ns, UdpDatagram* out) {
    Ipv4Packet ip;
    if (!is_ipv4_udp(decode_frame(link_type_, frame, size, &ip), ip, &stats_)) return false;
    const std::uint8_t* ip_payload = ip.payload;
    std::size_t ip_payload_size = ip.payload_size;
    bool reassembled = false;
    if (ip.is_fragment()) {
        ReassembledDatagram whole;
        const bool complete = reassembler_.add(to_fragment(ip, timestamp_ns), &whole);
        sync_reassembly_stats();
        if (!complete) return false;
        ip_payload = whole.payload;
        ip_payload_size = whole.size;
        reassembled = true;
    }
    UdpPayload udp;
    if (!decode_udp(ip_payload, ip_payload_size, &udp)) {
        ++stats_.malformed;
        return false;
    }
    out->timestamp_ns = timestamp_ns;
    out->src_ip = ip.src_ip;
    out->dst_ip = ip.dst_ip;
    out->src_port = udp.src_port;
    out->dst_port = udp.dst_port;
    out->data = udp.data;
    out->size = udp.size;
    out->reassembled = reassembled;
    ++stats_.udp_datagrams;
    return true;
}

bool PcapReader::next(UdpDatagram* out) {
    if (finished_) return false;
    for (;;) {
        pcap_pkthdr* header = nullptr;
        const u_char* frame = nullptr;
        const int rc = pcap_next_ex(handle_->pcap, &header, &frame);
        if (rc == PCAP_ERROR_BREAK) {  // end of file
            finish();
            return false;
        }
        if (rc != 1) {
            stop_after_read_error();
            return false;
        }
        ++stats_.records;
        // A classic pcap record: 16 bytes of header and the captured bytes (pcapng's blocks
        // are a little longer: an estimate there, for progress only).
        stats_.bytes_read += 16 + header->caplen;
        if (header->caplen < header->len) {
            ++stats_.truncated_records;
            continue;
        }
        // With nanosecond precision tv_usec holds nanoseconds.
        const std::int64_t timestamp_ns =
            static_cast<std::int64_t>(header->ts.tv_sec) * 1'000'000'000 +
            static_cast<std::int64_t>(header->ts.tv_usec);
        if (decode_record(frame, header->caplen, timestamp_ns, out)) return true;
    }
}

PcapReaderStats& PcapReaderStats::operator+=(const PcapReaderStats& o) {
    records += o.records;
    bytes_read += o.bytes_read;
    udp_datagrams += o.udp_datagrams;
    non_ipv4 += o.non_ipv4;
    non_udp += o.non_udp;
    malformed += o.malformed;
    truncated_records += o.truncated_records;
    fragments += o.fragments;
    reassembled += o.reassembled;
    dropped_incomplete += o.dropped_incomplete;
    discarded_fragments += o.discarded_fragments;
    cut_off += o.cut_off;
    read_errors += o.read_errors;
    return *this;
}

std::vector<std::filesystem::path> capture_files(const std::filesystem::path& path) {
    std::error_code error;
    if (std::filesystem::is_regular_file(path, error)) return {path};
    if (!std::filesystem::is_directory(path, error)) {
        throw std::runtime_error(path.string() + ": no such capture file or recording folder");
    }
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(path, error)) {
        if (entry.is_regular_file() && entry.path().extension() == ".pcap")
            files.push_back(entry.path());
    }
    if (error)
        throw std::runtime_error(path.string() + ": cannot list the folder: " + error.message());
    if (files.empty())
        throw std::runtime_error(path.string() + ": a folder without any .pcap file");
    std::sort(files.begin(), files.end());
    return files;
}

}  // namespace lidarfuse::pcap
