// Ouster packet decode + xyz throughput per UDP profile, on one core (rates are per second
// of this thread's CPU time, so a busy shared machine slows the run but not the figure
// much), compared with the
// line rate of an OS1-64 at 2048x10 (2048 columns / 16 per packet x 10 Hz = 1280 packets/s).
//
// Per packet: classify, CRC-64 check (non-legacy), packet header, every column header and
// every pixel field of the profile into staggered H x W frame arrays. Per frame (128
// packets): projection of the range image through the xyz lookup table. The packets are
// built with PacketFormat's writer (synthetic ranges); decoding cost does not depend on
// the values. Prints `name value unit` lines.

#include <time.h>

#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "drivers/ouster/packet_format.hpp"
#include "drivers/ouster/xyz_lut.hpp"

namespace {

using lidarfuse::ouster::CrcStatus;
using lidarfuse::ouster::Field;
using lidarfuse::ouster::PacketFormat;
using lidarfuse::ouster::PacketKind;
using lidarfuse::ouster::UdpProfileLidar;

constexpr int kRows = 64;
constexpr int kColumns = 2048;
constexpr int kColumnsPerPacket = 16;
constexpr double kLineRatePacketsPerS = 1280.0;
constexpr double kMinSeconds = 1.0;

// CPU time of the calling thread, seconds.
double thread_cpu_s() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Frame {
    std::vector<std::uint32_t> range, range2;
    std::vector<std::uint16_t> signal, signal2, near_ir;
    std::vector<std::uint8_t> refl, refl2;
    std::vector<std::uint64_t> timestamp, status;
    explicit Frame(std::size_t n)
        : range(n),
          range2(n),
          signal(n),
          signal2(n),
          near_ir(n),
          refl(n),
          refl2(n),
          timestamp(kColumns),
          status(kColumns) {}
};

std::vector<std::vector<std::uint8_t>> make_frame_packets(const PacketFormat& f) {
    std::mt19937 rng(1);
    std::vector<std::vector<std::uint8_t>> packets;
    for (int first = 0; first < kColumns; first += kColumnsPerPacket) {
        std::vector<std::uint8_t> p(f.lidar_packet_size(), 0);
        f.set_packet_type(p.data(), PacketFormat::kLidarPacketType);
        f.set_frame_id(p.data(), 42);
        f.set_init_id(p.data(), 1234);
        f.set_prod_sn(p.data(), 122239000672ULL);
        for (int c = 0; c < kColumnsPerPacket; ++c) {
            std::uint8_t* col = f.column(p.data(), c);
            f.set_column_timestamp_ns(col, 1000000ULL * static_cast<std::uint64_t>(first + c));
            f.set_column_measurement_id(col, static_cast<std::uint16_t>(first + c));
            f.set_column_status(col, 0xFFFFFFFFu);
            for (int r = 0; r < kRows; ++r) {
                std::uint8_t* px = f.pixel(col, r);
                const std::uint32_t range = rng() % 8 == 0 ? 0 : 500 + rng() % 60000;
                f.set_field(px, Field::kRange, range);
                f.set_field(px, Field::kRange2, range + 800);
                f.set_field(px, Field::kSignal, rng() % 2000);
                f.set_field(px, Field::kReflectivity, rng() % 256);
                f.set_field(px, Field::kNearIr, rng() % 4000);
            }
        }
        f.write_crc(p.data());
        packets.push_back(std::move(p));
    }
    return packets;
}

// Decodes one packet into the frame arrays; returns false when it is not accepted.
bool decode(const PacketFormat& f, const std::uint8_t* p, std::size_t size, Frame* frame) {
    if (f.classify(p, size) != PacketKind::kLidar) return false;
    if (f.check_crc(p) == CrcStatus::kInvalid) return false;
    if (f.frame_id(p) != 42 ||
        f.init_id(p) != (f.header_type() == lidarfuse::ouster::HeaderType::kLegacy ? 0u : 1234u)) {
        return false;
    }
    for (int c = 0; c < f.columns_per_packet(); ++c) {
        const std::uint8_t* col = f.column(p, c);
        const std::uint16_t m = f.column_measurement_id(col);
        if (m >= kColumns) return false;
        frame->timestamp[m] = f.column_timestamp_ns(col);
        frame->status[m] = f.column_status(col);
        f.read_column(col, Field::kRange, &frame->range[m], kColumns);
        f.read_column(col, Field::kRange2, &frame->range2[m], kColumns);
        f.read_column(col, Field::kSignal, &frame->signal[m], kColumns);
        f.read_column(col, Field::kSignal2, &frame->signal2[m], kColumns);
        f.read_column(col, Field::kReflectivity, &frame->refl[m], kColumns);
        f.read_column(col, Field::kReflectivity2, &frame->refl2[m], kColumns);
        f.read_column(col, Field::kNearIr, &frame->near_ir[m], kColumns);
    }
    return true;
}

// Runs whole frames for at least kMinSeconds; returns packets per second.
double measure(const PacketFormat& f, const std::vector<std::vector<std::uint8_t>>& packets,
               const lidarfuse::ouster::XyzLut* lut, std::vector<Eigen::Vector3f>* xyz,
               std::size_t* sink) {
    Frame frame(static_cast<std::size_t>(kRows) * kColumns);
    const double start = thread_cpu_s();
    double elapsed = 0.0;
    std::size_t n = 0;
    do {
        for (const auto& p : packets) {
            *sink += decode(f, p.data(), p.size(), &frame) ? 1 : 0;
        }
        if (lut != nullptr)
            *sink += lidarfuse::ouster::project(*lut, frame.range.data(), xyz->data());
        n += packets.size();
        elapsed = thread_cpu_s() - start;
    } while (elapsed < kMinSeconds);
    return static_cast<double>(n) / elapsed;
}

}  // namespace

int main() {
    struct Case {
        UdpProfileLidar profile;
        const char* name;
    };
    const Case cases[] = {
        {UdpProfileLidar::kLegacy, "legacy"},
        {UdpProfileLidar::kRng19Rfl8Sig16Nir16, "rng19"},
        {UdpProfileLidar::kRng15Rfl8Nir8, "rng15"},
        {UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual, "rng19_dual"},
        {UdpProfileLidar::kFusaRng15Rfl8Nir8Dual, "fusa_rng15_dual"},
    };
    // An OS1-64-like geometry for the lookup table (values do not change the cost).
    std::vector<double> altitude(kRows), azimuth(kRows);
    for (int r = 0; r < kRows; ++r) {
        altitude[static_cast<std::size_t>(r)] = 22.5 - 45.0 * r / (kRows - 1);
        azimuth[static_cast<std::size_t>(r)] = (r % 4 - 1.5) * 2.8;
    }
    Eigen::Matrix4d beam_to_lidar = Eigen::Matrix4d::Identity();
    beam_to_lidar(0, 3) = 15.806;
    const auto lut =
        lidarfuse::ouster::make_xyz_lut(kColumns, kRows, altitude, azimuth, beam_to_lidar,
                                        lidarfuse::ouster::default_lidar_to_sensor_transform());
    std::vector<Eigen::Vector3f> xyz(lut.size());
    std::size_t sink = 0;

    std::printf("ouster_parse_frame_geometry %dx%d rows_x_columns\n", kRows, kColumns);
    for (const Case& c : cases) {
        const PacketFormat f(c.profile, kRows, kColumnsPerPacket);
        const auto packets = make_frame_packets(f);
        const double decode_only = measure(f, packets, nullptr, nullptr, &sink);
        const double with_xyz = measure(f, packets, &lut, &xyz, &sink);
        std::printf("ouster_decode_%s_packets_per_s %.0f packets/s\n", c.name, decode_only);
        std::printf("ouster_parse_xyz_%s_packets_per_s %.0f packets/s\n", c.name, with_xyz);
        std::printf("ouster_parse_xyz_%s_line_rate_ratio %.1f x_os1_64_2048x10\n", c.name,
                    with_xyz / kLineRatePacketsPerS);
    }
    // Projection alone: points per second through the LUT.
    std::vector<std::uint32_t> range(lut.size(), 12345);
    const double start = thread_cpu_s();
    double elapsed = 0.0;
    std::size_t frames = 0;
    do {
        sink += lidarfuse::ouster::project(lut, range.data(), xyz.data());
        ++frames;
        elapsed = thread_cpu_s() - start;
    } while (elapsed < kMinSeconds);
    std::printf("ouster_xyz_project_points_per_s %.0f points/s\n",
                static_cast<double>(frames * lut.size()) / elapsed);
    std::fprintf(stderr, "(checksum %zu)\n", sink);
    return 0;
}
