// Ingest-level rows of the fault table that the drivers' unit tests do not already cover
// (tests/reliability/FAULTS.md maps every row): foreign sources and serials, a sensor whose
// profile or mode changed under its metadata, and column timestamps anywhere in 0..2^64-1.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/sensor_router.hpp"
#include "drivers/ouster/xyz_lut.hpp"

namespace lidarfuse::reliability {
namespace {

using ouster::PacketFormat;
using ouster::SensorInfo;
using ouster::UdpProfileLidar;

SensorInfo sensor(UdpProfileLidar profile, int columns, std::uint64_t serial, std::uint16_t port) {
    SensorInfo info;
    info.udp_profile_lidar = profile;
    info.columns_per_frame = columns;
    info.frames_per_second = 20;
    info.lidar_mode = std::to_string(columns) + "x20";
    info.column_window = {0, columns - 1};
    info.prod_sn = serial ? std::to_string(serial) : "";
    info.udp_port_lidar = port;
    info.beam_altitude_angles_deg.resize(64);
    info.beam_azimuth_angles_deg.assign(64, 0.0);
    for (int r = 0; r < 64; ++r) info.beam_altitude_angles_deg[static_cast<std::size_t>(r)] = 16.0 - 0.5 * r;
    info.pixel_shift_by_row.assign(64, 0);
    EXPECT_TRUE(ouster::validate_sensor_info(info).empty());
    return info;
}

// One lidar packet of `format`: columns first_column.., every pixel at 5 m, column
// timestamps `t0_ns + column * step_ns`.
std::vector<std::uint8_t> packet(const PacketFormat& format, std::uint32_t frame_id, int first_column,
                                 std::uint64_t serial, std::uint64_t t0_ns, std::uint64_t step_ns) {
    std::vector<std::uint8_t> p(format.lidar_packet_size(), 0);
    format.set_packet_type(p.data(), PacketFormat::kLidarPacketType);
    format.set_frame_id(p.data(), frame_id);
    format.set_init_id(p.data(), 7);
    format.set_prod_sn(p.data(), serial);
    for (int c = 0; c < format.columns_per_packet(); ++c) {
        std::uint8_t* col = format.column(p.data(), c);
        const auto m = static_cast<std::uint16_t>(first_column + c);
        format.set_column_measurement_id(col, m);
        format.set_column_timestamp_ns(col, t0_ns + m * step_ns);
        format.set_column_status(col, 0xFFFFFFFFu);
        for (int r = 0; r < format.pixels_per_column(); ++r) {
            format.set_field(format.pixel(col, r), ouster::Field::kRange, 5000);
        }
    }
    format.write_crc(p.data());
    return p;
}

constexpr std::uint64_t kSerial = 992233000111;
constexpr auto kRng19 = UdpProfileLidar::kRng19Rfl8Sig16Nir16;

// Row "packet from an unknown source address or serial": dropped, counted as foreign.
TEST(IngestFaults, ForeignSourceAddressAndForeignSerialAreNotTakenForTheSensor) {
    const SensorInfo a = sensor(kRng19, 1024, kSerial, 7502);
    const SensorInfo b = sensor(kRng19, 1024, kSerial + 1, 7502);
    const PacketFormat format(a);
    const auto pa = packet(format, 1, 0, kSerial, 1'000'000, 48'828);
    const auto foreign = packet(format, 1, 0, 123456789, 1'000'000, 48'828);

    // Two sensors share port 7502, a's address is configured: another address is foreign.
    ouster::SensorRouter router({{a, 0x0A000001u}, {b, std::nullopt}});
    EXPECT_EQ(router.route(0x0A000001u, 7502, pa.data(), pa.size()), 0);
    EXPECT_EQ(router.route(0x0A000099u, 7502, foreign.data(), foreign.size()), ouster::SensorRouter::kUnassigned);
    EXPECT_EQ(router.route(0x0A000001u, 7999, pa.data(), pa.size()), ouster::SensorRouter::kUnassigned);
    EXPECT_EQ(router.counters().unassigned, 2u);

    // A sensor alone on its port: a packet with another serial reaches its assembler
    // (rule 6), which refuses it as the wrong sensor, counts it, and assembles nothing.
    int frames = 0;
    ouster::ScanAssembler assembler(a, {}, [&](const ouster::LidarScan&) { ++frames; });
    EXPECT_EQ(assembler.add_packet(foreign.data(), foreign.size()), ouster::PacketOutcome::kWrongProfile);
    assembler.flush();
    EXPECT_EQ(assembler.counters().bad_profile, 1u);
    EXPECT_EQ(assembler.counters().lidar_packets, 0u);
    EXPECT_EQ(frames, 0);
}

// Row "profile or mode changed on the sensor": a profile change changes the packet size
// (every packet counted bad, no scan ever emitted, so the sensor goes LOST); a mode change
// 1024 -> 512 columns keeps the size, and shows as frames that never complete, each
// missing the columns 512..1023 it was told to expect.
TEST(IngestFaults, ProfileOrModeChangedUnderTheMetadataIsCountedAndNeverComplete) {
    const SensorInfo configured = sensor(kRng19, 1024, kSerial, 7502);
    {
        const PacketFormat legacy(sensor(UdpProfileLidar::kLegacy, 1024, 0, 7502));
        int frames = 0;
        ouster::ScanAssembler assembler(configured, {}, [&](const ouster::LidarScan&) { ++frames; });
        for (int p = 0; p < 64; ++p) {
            const auto pkt = packet(legacy, 1, p * 16, 0, 0, 48'828);
            EXPECT_EQ(assembler.add_packet(pkt.data(), pkt.size()), ouster::PacketOutcome::kWrongSize);
        }
        assembler.flush();
        EXPECT_EQ(assembler.counters().bad_size, 64u);
        EXPECT_EQ(frames, 0);
    }
    {
        const PacketFormat now(sensor(kRng19, 512, kSerial, 7502));
        std::vector<double> completeness;
        ouster::ScanAssembler assembler(configured, {},
                                        [&](const ouster::LidarScan& s) { completeness.push_back(s.completeness()); });
        for (std::uint32_t frame = 1; frame <= 4; ++frame) {
            for (int p = 0; p < 32; ++p) {
                const auto pkt = packet(now, frame, p * 16, kSerial, frame * 50'000'000ull, 97'656);
                assembler.add_packet(pkt.data(), pkt.size());
            }
        }
        assembler.flush();
        ASSERT_EQ(completeness.size(), 4u);
        for (double c : completeness) EXPECT_DOUBLE_EQ(c, 0.5);
        EXPECT_EQ(assembler.counters().frames_complete, 0u);
        EXPECT_EQ(assembler.counters().frames_incomplete, 4u);
        EXPECT_EQ(assembler.counters().missing_columns, 4u * 512u);
    }
}

// Found by fuzz/fuzz_ouster_packets: column timestamps far apart (a corrupted column, a
// clock jump inside a frame) made point_times_s() overflow a signed subtraction
// (undefined behaviour; UBSan aborts). Now every point gets a finite time relative to
// the reference, with the right sign.
TEST(IngestFaults, ColumnTimestampsAnywhereInTheRangeGiveFinitePointTimes) {
    const SensorInfo info = sensor(kRng19, 512, kSerial, 7502);
    const PacketFormat format(info);
    const ouster::XyzLut lut = ouster::make_xyz_lut(info);
    const std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
    for (const auto& [t0, step] : std::vector<std::pair<std::uint64_t, std::uint64_t>>{
             {0, kMax / 600}, {kMax - 512, 1}, {1ull << 63, 1ull << 50}, {5, 0}}) {
        std::vector<std::vector<float>> times;
        ouster::ScanCloud cloud;
        ouster::ScanAssembler assembler(info, {}, [&](const ouster::LidarScan& scan) {
            ASSERT_TRUE(ouster::project_scan(scan, lut, {}, &cloud));
            times.emplace_back();
            ouster::point_times_s(cloud, ouster::scan_reference_time_ns(scan), &times.back());
        });
        for (int p = 0; p < 32; ++p) {
            const auto pkt = packet(format, 3, p * 16, kSerial, t0, step);
            assembler.add_packet(pkt.data(), pkt.size());
        }
        ASSERT_EQ(times.size(), 1u);
        ASSERT_EQ(times[0].size(), 512u * 64u);
        for (float t : times[0]) {
            ASSERT_TRUE(std::isfinite(t));
            ASSERT_GE(t, 0.0f);  // column 0 is the reference and the earliest
        }
    }
    // A reference after the points: negative times, no wrap-around.
    ouster::ScanCloud cloud;
    cloud.columns = 2;
    cloud.rows = 1;
    cloud.cloud.points.resize(2);
    cloud.pixel_index = {0, 1};
    cloud.column_timestamp_ns = {0, kMax};
    std::vector<float> t;
    ouster::point_times_s(cloud, kMax, &t);
    ASSERT_EQ(t.size(), 2u);
    EXPECT_LT(t[0], -1e9f);
    EXPECT_EQ(t[1], 0.0f);
}

}  // namespace
}  // namespace lidarfuse::reliability
