#pragma once
// Synthetic Ouster lidar packets for the assembler and projection tests
// (ouster_scan_assembler_test, ouster_projection_test): a sensor of 16 x 64 pixels, 8 columns
// per packet, whose pixel values are known functions of row, column and frame, written with
// PacketFormat's encoder, and an assembler that records what it emits. A header, so that a
// bundled build compiling both in one unit defines them once.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"
#include "drivers/ouster/scan_assembler.hpp"

namespace lidarfuse::ouster::packet_rig {

constexpr std::uint64_t kSerial = 992210000957ull;
constexpr std::uint32_t kInitId = 0x123456;

inline SensorInfo make_info(UdpProfileLidar profile, int rows = 16, int columns = 64,
                            std::array<int, 2> window = {-1, -1}) {
    SensorInfo info;
    info.prod_sn = std::to_string(kSerial);
    info.udp_profile_lidar = profile;
    info.pixels_per_column = rows;
    info.columns_per_frame = columns;
    info.columns_per_packet = 8;
    info.column_window = window[0] < 0 ? std::array<int, 2>{0, columns - 1} : window;
    info.init_id = kInitId;
    for (int r = 0; r < rows; ++r) {
        info.beam_altitude_angles_deg.push_back(15.0 - 2.0 * r);
        info.beam_azimuth_angles_deg.push_back(r % 2 ? 1.5 : -1.5);
    }
    info.pixel_shift_by_row.assign(static_cast<std::size_t>(rows), 0);
    return info;
}

// Deterministic pixel values every profile can represent exactly.
inline std::uint32_t range_of(int row, int mid, std::uint32_t frame) {
    return 8u * static_cast<std::uint32_t>((row * 7 + mid + static_cast<int>(frame)) % 4000 + 1);
}
inline std::uint32_t range2_of(int row, int mid) {
    return 8u * static_cast<std::uint32_t>(row + mid + 100);
}
inline std::uint32_t signal_of(int row, int mid) {
    return static_cast<std::uint32_t>(row * 100 + mid);
}
inline std::uint32_t refl_of(int row, int mid) {
    return static_cast<std::uint32_t>((row * 3 + mid) % 256);
}
inline std::uint32_t nir_of(int row, int mid) {
    return 16u * static_cast<std::uint32_t>((row + mid) % 256);
}

class PacketWriter {
public:
    explicit PacketWriter(const SensorInfo& info)
        : info_(info), format_(info), buffer_(format_.lidar_packet_size(), 0) {}

    // The packet with columns [first_col, first_col + columns_per_packet) of `frame`.
    // Columns outside `valid` (a window) get status 0 and zero data, as sensors send them.
    const std::vector<std::uint8_t>& packet(std::uint32_t frame, int first_col,
                                            std::uint32_t init_id = kInitId,
                                            std::uint64_t serial = kSerial) {
        std::fill(buffer_.begin(), buffer_.end(), 0);
        std::uint8_t* pkt = buffer_.data();
        format_.set_packet_type(pkt, PacketFormat::kLidarPacketType);
        format_.set_frame_id(pkt, frame);
        format_.set_init_id(pkt, init_id);
        format_.set_prod_sn(pkt, serial);
        const ColumnWindow window{static_cast<std::uint32_t>(info_.column_window[0]),
                                  static_cast<std::uint32_t>(info_.column_window[1])};
        const bool legacy = format_.header_type() == HeaderType::kLegacy;
        for (int i = 0; i < format_.columns_per_packet(); ++i) {
            std::uint8_t* col = format_.column(pkt, i);
            const int mid = (first_col + i) % info_.columns_per_frame;
            format_.set_column_measurement_id(col, static_cast<std::uint16_t>(mid));
            format_.set_column_timestamp_ns(col, 1'000'000'000ull * frame + 1000ull * mid);
            if (legacy) format_.set_column_frame_id(col, static_cast<std::uint16_t>(frame));
            if (!window.contains(static_cast<std::uint32_t>(mid))) continue;
            format_.set_column_status(col, legacy ? 0xFFFFFFFFu : 1u);
            for (int row = 0; row < format_.pixels_per_column(); ++row) {
                std::uint8_t* px = format_.pixel(col, row);
                format_.set_field(px, Field::kRange, range_of(row, mid, frame));
                format_.set_field(px, Field::kRange2, range2_of(row, mid));
                format_.set_field(px, Field::kSignal, signal_of(row, mid));
                format_.set_field(px, Field::kSignal2, signal_of(row, mid) + 1);
                format_.set_field(px, Field::kReflectivity, refl_of(row, mid));
                format_.set_field(px, Field::kReflectivity2, 255 - refl_of(row, mid));
                format_.set_field(px, Field::kNearIr, nir_of(row, mid));
            }
        }
        format_.write_crc(pkt);
        return buffer_;
    }
    const PacketFormat& format() const { return format_; }

private:
    SensorInfo info_;
    PacketFormat format_;
    std::vector<std::uint8_t> buffer_;
};

struct Frame {
    std::uint32_t frame_id;
    bool complete;
    double completeness;
};

// An assembler with a writer for the same sensor; records every emitted frame and keeps a
// copy of the last one.
struct Rig {
    explicit Rig(const SensorInfo& info, ScanAssemblerParams params = {})
        : writer(info), assembler(info, params, [this](const LidarScan& s) {
              frames.push_back({s.frame_id, s.complete(), s.completeness()});
              last = s;
          }) {
        frames.reserve(64);
    }
    PacketOutcome send(std::uint32_t frame, int first_col, std::uint32_t init_id = kInitId,
                       std::uint64_t serial = kSerial) {
        const auto& p = writer.packet(frame, first_col, init_id, serial);
        return assembler.add_packet(p.data(), p.size());
    }
    void send_frame(std::uint32_t frame, int columns = 64) {
        for (int c = 0; c < columns; c += 8) send(frame, c);
    }

    PacketWriter writer;
    ScanAssembler assembler;
    std::vector<Frame> frames;
    LidarScan last;
};

}  // namespace lidarfuse::ouster::packet_rig
