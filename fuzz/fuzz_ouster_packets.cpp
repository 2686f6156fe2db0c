// libFuzzer harness: Ouster UDP datagrams -> PacketFormat -> ScanAssembler -> projection.
//
// Input (see fuzz_input.hpp): a 16-byte sensor description, then length-prefixed
// datagrams fed in order to one ScanAssembler, then flush().
//   byte 0   bits 0-2 profile (mod 5), bits 3-4 frames_in_flight - 1, bit 5 CRC check off
//   byte 1   columns_per_frame 512 / 1024 / 2048 (mod 3)
//   byte 2   pixels_per_column 16 / 32 / 64 / 128 (mod 4)
//   byte 3   columns_per_packet 16 / 8 / 32 / 4 (mod 4)
//   bytes 4-7   column window first, last (u16 each, mod columns_per_frame)
//   bytes 8-15  40-bit serial the headers must carry (0: none)
// Checked besides memory safety: every datagram is counted exactly once, every emitted
// frame is counted complete or incomplete, completeness stays in [0, 1], and a frame
// always projects through the LUT of its sensor.
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "fuzz/fuzz_input.hpp"
#include "fuzz/packet_shapes.hpp"

namespace {

using namespace lidarfuse;

constexpr const auto& kProfiles = fuzz::kPacketProfiles;
constexpr const auto& kColumns = fuzz::kPacketColumns;
constexpr const auto& kRows = fuzz::kPacketRows;
constexpr const auto& kColumnsPerPacket = fuzz::kPacketColumnsPerPacket;

ouster::SensorInfo make_info(fuzz::FuzzInput& in, std::size_t* frames_in_flight, bool* check_crc) {
    ouster::SensorInfo info;
    const std::uint8_t b0 = in.byte();
    info.udp_profile_lidar = kProfiles[(b0 & 7) % 5];
    *frames_in_flight = 1 + ((b0 >> 3) & 3);
    *check_crc = (b0 & 0x20) == 0;
    info.columns_per_frame = kColumns[in.byte() % 3];
    info.frames_per_second = info.columns_per_frame == 2048 ? 10 : 20;
    info.lidar_mode =
        std::to_string(info.columns_per_frame) + "x" + std::to_string(info.frames_per_second);
    info.pixels_per_column = kRows[in.byte() % 4];
    info.columns_per_packet = kColumnsPerPacket[in.byte() % 4];
    info.column_window[0] = in.u16() % info.columns_per_frame;
    info.column_window[1] = in.u16() % info.columns_per_frame;
    const std::uint64_t serial = in.u64() & 0xFFFFFFFFFFull;
    if (serial != 0) info.prod_sn = std::to_string(serial);
    const int h = info.pixels_per_column;
    info.beam_altitude_angles_deg.resize(static_cast<std::size_t>(h));
    info.beam_azimuth_angles_deg.resize(static_cast<std::size_t>(h));
    for (int r = 0; r < h; ++r) {
        info.beam_altitude_angles_deg[static_cast<std::size_t>(r)] = 22.5 - 45.0 * r / (h - 1);
        info.beam_azimuth_angles_deg[static_cast<std::size_t>(r)] = (r % 4) * 1.5 - 2.25;
    }
    info.pixel_shift_by_row =
        ouster::default_pixel_shift_by_row(info.beam_azimuth_angles_deg, h, info.columns_per_frame);
    info.lidar_to_sensor_transform = ouster::default_lidar_to_sensor_transform();
    return info;
}

// The LUT depends only on W and H here (the beams are generated from H): built once each.
const ouster::XyzLut& lut_for(const ouster::SensorInfo& info) {
    static std::map<std::pair<int, int>, ouster::XyzLut> cache;
    const auto key = std::make_pair(info.columns_per_frame, info.pixels_per_column);
    auto it = cache.find(key);
    if (it == cache.end()) it = cache.emplace(key, ouster::make_xyz_lut(info)).first;
    return it->second;
}

// Reads every header accessor of a datagram the format calls a lidar packet.
std::uint64_t read_headers(const ouster::PacketFormat& format, const std::uint8_t* pkt) {
    std::uint64_t sum = format.packet_type(pkt) + format.frame_id(pkt) + format.init_id(pkt) +
                        format.prod_sn(pkt) + format.alert_flags(pkt) +
                        format.countdown_thermal_shutdown(pkt) +
                        format.countdown_shot_limiting(pkt) + format.thermal_shutdown(pkt) +
                        format.shot_limiting(pkt) + format.stored_crc(pkt);
    for (int c = 0; c < format.columns_per_packet(); ++c) {
        const std::uint8_t* col = format.column(pkt, c);
        sum += format.column_timestamp_ns(col) + format.column_measurement_id(col) +
               format.column_status(col) + format.column_frame_id(col) +
               format.column_encoder_count(col);
        const std::uint8_t* last = format.pixel(col, format.pixels_per_column() - 1);
        sum += format.range_mm(last) + format.range2_mm(last) + format.signal(last) +
               format.signal2(last) + format.reflectivity(last) + format.reflectivity2(last) +
               format.near_ir(last);
    }
    return sum;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    fuzz::FuzzInput in(data, size);
    std::size_t frames_in_flight = 2;
    bool check_crc = true;
    const ouster::SensorInfo info = make_info(in, &frames_in_flight, &check_crc);
    // Only metadata the loader would accept reaches an assembler in the daemon.
    if (!ouster::validate_sensor_info(info).empty()) return 0;

    ouster::ScanAssemblerParams params;
    params.window.frames_in_flight = frames_in_flight;
    params.check_crc = check_crc;
    const ouster::XyzLut& lut = lut_for(info);
    ouster::ScanCloud cloud;
    std::vector<float> times;
    std::uint64_t emitted = 0;
    ouster::ScanAssembler assembler(info, params, [&](const ouster::LidarScan& scan) {
        ++emitted;
        const double completeness = scan.completeness();
        if (!(completeness >= 0.0 && completeness <= 1.0)) fuzz::invariant_failed("completeness");
        if (!ouster::project_scan(scan, lut, ouster::ProjectionParams{}, &cloud)) {
            fuzz::invariant_failed("a scan does not project through its sensor's LUT");
        }
        if (cloud.cloud.points.size() > scan.rows() * scan.columns())
            fuzz::invariant_failed("points");
        ouster::point_times_s(cloud, ouster::scan_reference_time_ns(scan), &times);
    });

    const ouster::PacketFormat& format = assembler.format();
    volatile std::uint64_t sink = 0;
    const std::uint8_t* datagram = nullptr;
    std::size_t datagram_size = 0;
    std::uint64_t offered = 0;
    while (in.record(&datagram, &datagram_size)) {
        ++offered;
        if (format.classify(datagram, datagram_size) == ouster::PacketKind::kLidar) {
            sink = sink + read_headers(format, datagram);
        }
        assembler.add_packet(datagram, datagram_size);
    }
    assembler.flush();

    const ouster::AssemblyCounters& c = assembler.counters();
    if (c.packets != offered) fuzz::invariant_failed("packets != datagrams offered");
    if (c.packets != c.lidar_packets + c.imu_packets + c.bad_size + c.bad_profile + c.crc_errors) {
        fuzz::invariant_failed("packet counters do not add up");
    }
    if (c.late_packets + c.duplicate_packets > c.lidar_packets)
        fuzz::invariant_failed("late + duplicate");
    if (c.frames_complete + c.frames_incomplete != emitted)
        fuzz::invariant_failed("frame counters");
    return 0;
}
