// libFuzzer harness: a capture file (pcap or pcapng) -> PcapReader (libpcap, link-layer
// decoding, IPv4 reassembly) -> UDP datagrams.
//
// The input is written to a file of this process (the reader takes a path, as the tools
// do). Checked besides memory safety: opening either succeeds or throws
// std::runtime_error; every datagram's bytes can be read; no datagram is larger than an
// IPv4 payload can be; the counters add up (records are each delivered, skipped or
// fragments, and fragments end reassembled or discarded).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include "drivers/pcap/pcap_reader.hpp"
#include "fuzz/fuzz_input.hpp"

using namespace lidarfuse;

namespace {

// The reader takes a file: each input is written to one, removed when the fuzzer exits
// (libFuzzer ends a timed run with exit(), which runs static destructors), so that runs
// leave nothing in the temporary folder.
struct InputFile {
    std::filesystem::path path = std::filesystem::temp_directory_path() /
                                 ("lidarfuse_fuzz_pcap_" + std::to_string(getpid()) + ".pcap");
    ~InputFile() {
        std::error_code ignored;
        std::filesystem::remove(path, ignored);
    }
};

const std::filesystem::path& input_file() {
    static const InputFile file;
    return file.path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto file = input_file();
    {
        std::FILE* f = std::fopen(file.c_str(), "wb");
        if (!f) fuzz::invariant_failed("cannot write the input file");
        if (size > 0 && std::fwrite(data, 1, size, f) != size)
            fuzz::invariant_failed("short write");
        std::fclose(f);
    }
    pcap::PcapReaderParams params;
    params.reassembly.max_entries = 4;  // small table: eviction paths are reached too
    try {
        pcap::PcapReader reader(file, params);
        pcap::UdpDatagram d;
        volatile std::uint64_t sink = 0;
        std::uint64_t delivered = 0;
        while (reader.next(&d)) {
            ++delivered;
            if (d.size > pcap::Ipv4Reassembler::kMaxPayloadBytes)
                fuzz::invariant_failed("datagram size");
            std::uint64_t sum = 0;
            for (std::size_t i = 0; i < d.size; ++i) sum += d.data[i];
            sink = sink + sum;
        }
        const auto& s = reader.stats();
        if (s.udp_datagrams != delivered) fuzz::invariant_failed("udp_datagrams != delivered");
        if (s.reassembled > s.fragments) fuzz::invariant_failed("more reassembled than fragments");
        if (s.udp_datagrams > s.records) fuzz::invariant_failed("more datagrams than records");
    } catch (const std::runtime_error&) {
        // Not a capture, or a link type the reader does not decode: refused at open.
    }
    return 0;
}
