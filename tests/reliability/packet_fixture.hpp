#pragma once
// Shared by the ingest-level reliability tests: a minimal OS1-64 description and lidar
// packets built with PacketFormat's setters (every pixel at 5 m, column timestamps on a
// line), so a test says exactly which columns, ids and times a sensor sends.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"

namespace lidarfuse::reliability {

constexpr std::uint64_t kSerial = 992233000111;
constexpr auto kRng19 = ouster::UdpProfileLidar::kRng19Rfl8Sig16Nir16;

inline ouster::SensorInfo sensor(ouster::UdpProfileLidar profile, int columns, std::uint64_t serial,
                                 std::uint16_t port, int fps = 20) {
    ouster::SensorInfo info;
    info.udp_profile_lidar = profile;
    info.columns_per_frame = columns;
    info.frames_per_second = fps;
    info.lidar_mode = std::to_string(columns) + "x" + std::to_string(fps);
    info.column_window = {0, columns - 1};
    info.prod_sn = serial ? std::to_string(serial) : "";
    info.udp_port_lidar = port;
    info.beam_altitude_angles_deg.resize(64);
    info.beam_azimuth_angles_deg.assign(64, 0.0);
    for (int r = 0; r < 64; ++r)
        info.beam_altitude_angles_deg[static_cast<std::size_t>(r)] = 16.0 - 0.5 * r;
    info.pixel_shift_by_row.assign(64, 0);
    EXPECT_TRUE(ouster::validate_sensor_info(info).empty());
    return info;
}

// One lidar packet of `format`: columns first_column.., every pixel at 5 m, column
// timestamps `t0_ns + column * step_ns`.
inline std::vector<std::uint8_t> packet(const ouster::PacketFormat& format, std::uint32_t frame_id,
                                        int first_column, std::uint64_t serial, std::uint64_t t0_ns,
                                        std::uint64_t step_ns) {
    std::vector<std::uint8_t> p(format.lidar_packet_size(), 0);
    format.set_packet_type(p.data(), ouster::PacketFormat::kLidarPacketType);
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

}  // namespace lidarfuse::reliability
