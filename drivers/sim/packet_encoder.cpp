#include "drivers/sim/packet_encoder.hpp"

#include <cstring>

namespace lidarfuse::sim {

void encode_lidar_packet(const ouster::PacketFormat& f, const PacketHeaderValues& h, int first_m,
                         int columns_per_frame, const std::uint64_t* ts, const PixelReturn* pixels,
                         std::uint8_t* pkt) {
    using ouster::Field;
    std::memset(pkt, 0, f.lidar_packet_size());
    const bool legacy = f.header_type() == ouster::HeaderType::kLegacy;
    if (!legacy) {
        f.set_packet_type(pkt, ouster::PacketFormat::kLidarPacketType);
        f.set_init_id(pkt, h.init_id);
        f.set_prod_sn(pkt, h.serial);
        f.set_countdown_thermal_shutdown(pkt, 0);
        f.set_countdown_shot_limiting(pkt, 0);
    }
    const int rows = f.pixels_per_column();
    for (int c = 0; c < f.columns_per_packet(); ++c) {
        std::uint8_t* col = f.column(pkt, c);
        const int m = first_m + c;
        f.set_column_timestamp_ns(col, ts[c]);
        f.set_column_measurement_id(col, static_cast<std::uint16_t>(m));
        if (legacy) {
            f.set_column_status(col, 0xFFFFFFFFu);
            f.set_column_encoder_count(
                col, static_cast<std::uint32_t>(static_cast<std::uint64_t>(m) * 90112u /
                                                static_cast<std::uint64_t>(columns_per_frame)));
        } else {
            f.set_column_status(col, 0x1u);
        }
        for (int r = 0; r < rows; ++r) {
            const PixelReturn& p = pixels[c * rows + r];
            std::uint8_t* px = f.pixel(col, r);
            f.set_field(px, Field::kRange, p.range_mm);
            f.set_field(px, Field::kReflectivity, p.reflectivity);
            f.set_field(px, Field::kSignal, p.signal);
            f.set_field(px, Field::kNearIr, p.near_ir);
        }
    }
    f.set_frame_id(pkt, h.frame_id);  // LEGACY: into every column header
    f.write_crc(pkt);
}

}  // namespace lidarfuse::sim
