// Parse + assemble + project throughput of the Ouster ingest path, per UDP profile, on the
// real packets of the sample captures replayed many times with incremented frame ids.
// One thread; rates are per core of thread CPU time (not wall time, which the shared
// machine inflates). Compared with the line rate of an OS1-64 at 2048x10: 2048 columns /
// 16 per packet x 10 Hz = 1280 packets/s.
//
// usage: ouster_assemble_bench [DATA_DIR] [FRAMES_PER_PROFILE=300]
// Prints `name value unit` lines.
#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "drivers/pcap/pcap_reader.hpp"

namespace {

using namespace lidarfuse;

constexpr double kOs1LineRatePacketsPerS = 1280.0;

struct Case {
    const char* name;  // profile (and sensor) in the output
    const char* capture;
    const char* metadata;
};

double thread_cpu_s() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void run_case(const std::filesystem::path& dir, const Case& c, int frames) {
    const auto info = ouster::load_metadata(dir / c.metadata);
    const ouster::PacketFormat format(info);
    std::vector<std::vector<std::uint8_t>> packets;
    pcap::PcapReader reader(dir / c.capture);
    pcap::UdpDatagram d;
    while (reader.next(&d)) {
        if (format.classify(d.data, d.size) == ouster::PacketKind::kLidar) {
            packets.emplace_back(d.data, d.data + d.size);
        }
    }
    if (packets.empty()) {
        std::fprintf(stderr, "%s: no lidar packets\n", c.capture);
        return;
    }
    const std::uint32_t first_frame = format.frame_id(packets.front().data());

    const ouster::XyzLut lut = ouster::make_xyz_lut(info);
    ouster::ScanCloud cloud;
    std::uint64_t points = 0;
    std::uint64_t frames_out = 0;
    ouster::ScanAssembler assembler(info, {}, [&](const ouster::LidarScan& scan) {
        ouster::project_scan(scan, lut, {}, &cloud);
        points += cloud.cloud.size();
        ++frames_out;
    });

    // One warm-up frame (first use of the pool and of the cloud's capacity), then timing.
    std::uint64_t sent = 0;
    double t0 = 0.0;
    for (int f = -1; f < frames; ++f) {
        if (f == 0) {
            t0 = thread_cpu_s();
            points = 0;
            frames_out = 0;
            sent = 0;
        }
        const std::uint32_t id = first_frame + static_cast<std::uint32_t>(f + 1);
        for (auto& p : packets) {
            format.set_frame_id(p.data(), id);
            assembler.add_packet(p.data(), p.size());
            ++sent;
        }
    }
    assembler.flush();
    const double cpu_s = thread_cpu_s() - t0;
    const double rate = static_cast<double>(sent) / cpu_s;
    const auto& k = assembler.counters();
    std::printf("ouster_assemble_%s_packet_bytes %zu B\n", c.name, format.lidar_packet_size());
    std::printf("ouster_assemble_%s_pixels_per_packet %d pixels\n", c.name,
                format.pixels_per_column() * format.columns_per_packet());
    std::printf("ouster_assemble_%s_packets_per_s %.0f packets/s\n", c.name, rate);
    std::printf("ouster_assemble_%s_ns_per_packet %.0f ns\n", c.name, 1e9 / rate);
    std::printf("ouster_assemble_%s_points_per_s %.0f points/s\n", c.name,
                static_cast<double>(points) / cpu_s);
    std::printf("ouster_assemble_%s_vs_os1_64_2048x10_line_rate %.1f ratio\n", c.name,
                rate / kOs1LineRatePacketsPerS);
    std::printf("ouster_assemble_%s_frames %llu frames\n", c.name,
                static_cast<unsigned long long>(frames_out));
    if (k.frames_incomplete + k.late_packets + k.bad_profile + k.crc_errors != 0) {
        std::fprintf(stderr, "%s: unexpected loss (incomplete %llu, late %llu)\n", c.name,
                     static_cast<unsigned long long>(k.frames_incomplete),
                     static_cast<unsigned long long>(k.late_packets));
    }
}

}  // namespace

int main(int argc, char** argv) {
    const std::filesystem::path data = argc > 1 ? std::filesystem::path(argv[1])
                                                : std::filesystem::path(LIDARFUSE_DEFAULT_DATA_DIR);
    const int frames = argc > 2 ? std::atoi(argv[2]) : 300;
    const std::filesystem::path dir = data / "ouster";
    if (!std::filesystem::is_directory(dir)) {
        std::fprintf(stderr, "sample captures not found in %s\n", dir.c_str());
        return 1;
    }
    const Case cases[] = {
        {"legacy_os1_64", "OS-1-64_1024x10_fw20.pcap", "OS-1-64_sensor_config_reduced.json"},
        {"legacy_os1_32", "OS-1-32-G_v2.1.1_1024x10.pcap", "OS-1-32-G_v2.1.1_1024x10.json"},
        {"rng19_os2_128", "OS-2-128-U1_v2.3.0_1024x10.pcap", "OS-2-128-U1_v2.3.0_1024x10.json"},
        {"rng15_os0_128", "OS-0-128-U1_v2.3.0_1024x10.pcap", "OS-0-128-U1_v2.3.0_1024x10.json"},
        {"rng19_dual_os0_32", "OS-0-32-U1_v2.2.0_1024x10.pcap", "OS-0-32-U1_v2.2.0_1024x10.json"},
    };
    for (const auto& c : cases) run_case(dir, c, frames);
    std::printf("ouster_assemble_os1_64_2048x10_line_rate %.0f packets/s\n",
                kOs1LineRatePacketsPerS);
    return 0;
}
