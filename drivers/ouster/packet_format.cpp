// PacketFormat: classifying, reading and writing packets, and their CRC-64, on the
// layouts of packet_layouts.cpp.

#include "drivers/ouster/packet_format.hpp"

#include <array>
#include <stdexcept>
#include <string>

namespace lidarfuse::ouster {
namespace {

constexpr std::size_t kMaxUdpPayload = 65507;

void store(std::uint8_t* p, std::uint64_t value, std::size_t bytes) {
    std::memcpy(p, &value, bytes);  // little-endian host
}

std::uint64_t fetch(const std::uint8_t* p, std::size_t bytes) {
    std::uint64_t v = 0;
    std::memcpy(&v, p, bytes);
    return v;
}

// Replaces the field's bits, keeping those of neighboring fields in the same bytes.
void store_masked(std::uint8_t* p, const HeaderFieldSpec& s, std::uint64_t value) {
    store(p, (fetch(p, s.bytes) & ~s.mask) | (value & s.mask), s.bytes);
}

// Reflected CRC-64/XZ tables for slicing-by-8 (table[0] is the classic byte table;
// table[k][b] advances table[k-1][b] by one more zero byte), built at compile time.
using CrcTables = std::array<std::array<std::uint64_t, 256>, 8>;
constexpr CrcTables make_crc_tables() {
    CrcTables t{};
    constexpr std::uint64_t kReflectedPoly = 0xC96C5795D7870F42ULL;
    for (std::uint64_t i = 0; i < 256; ++i) {
        std::uint64_t c = i;
        for (int k = 0; k < 8; ++k) c = (c & 1U) != 0 ? (c >> 1) ^ kReflectedPoly : c >> 1;
        t[0][i] = c;
    }
    for (std::size_t k = 1; k < 8; ++k) {
        for (std::size_t i = 0; i < 256; ++i) {
            t[k][i] = (t[k - 1][i] >> 8) ^ t[0][t[k - 1][i] & 0xFFU];
        }
    }
    return t;
}
constexpr CrcTables kCrcTables = make_crc_tables();

// `count` columns `column_size` apart, row by row (see PacketFormat::read_columns); one
// column is count 1. Fixed-width loads keep the per-pixel memcpy inlined (a runtime size
// would be a call).
template <std::size_t N, typename T>
void read_rows_n(const std::uint8_t* px, std::size_t column_size, std::size_t step, int rows,
                 int count, const FieldSpec& s, T* dst, std::ptrdiff_t stride) {
    for (int row = 0; row < rows; ++row, px += step, dst += stride) {
        const std::uint8_t* p = px;
        for (int c = 0; c < count; ++c, p += column_size) {
            std::uint32_t v = 0;
            std::memcpy(&v, p, N);
            dst[c] = static_cast<T>((v & s.mask) << s.upshift);
        }
    }
}

// One field of `count` columns from the column at `col`, `column_size` bytes apart.
template <typename T>
void read_pixels(const PacketFormat& f, const std::uint8_t* col, std::size_t column_size, int count,
                 Field field, T* dst, std::ptrdiff_t stride) {
    const FieldSpec s = f.spec(field);
    const std::uint8_t* px = f.pixel(col, 0) + s.offset;
    const std::size_t step = f.pixel_size();
    const int rows = f.pixels_per_column();
    switch (s.bytes) {
        case 1:
            read_rows_n<1>(px, column_size, step, rows, count, s, dst, stride);
            break;
        case 2:
            read_rows_n<2>(px, column_size, step, rows, count, s, dst, stride);
            break;
        case 4:
            read_rows_n<4>(px, column_size, step, rows, count, s, dst, stride);
            break;
        default:
            break;  // absent field
    }
}

template <typename T>
void read_columns_impl(const PacketFormat& f, const std::uint8_t* pkt, int first, int count,
                       Field field, T* dst, std::ptrdiff_t stride) {
    const std::uint8_t* col = f.column(pkt, first);
    const std::size_t column_size =
        count > 1 ? static_cast<std::size_t>(f.column(pkt, first + 1) - col) : 0;
    read_pixels(f, col, column_size, count, field, dst, stride);
}

}  // namespace

const char* to_string(Field field) {
    constexpr const char* kNames[] = {"RANGE",        "RANGE2",        "SIGNAL", "SIGNAL2",
                                      "REFLECTIVITY", "REFLECTIVITY2", "NEAR_IR"};
    return kNames[static_cast<int>(field)];
}

const char* to_string(PacketKind kind) {
    switch (kind) {
        case PacketKind::kLidar:
            return "lidar";
        case PacketKind::kImu:
            return "imu";
        case PacketKind::kWrongSize:
            return "wrong size";
        case PacketKind::kWrongProfile:
            return "wrong profile";
    }
    return "unknown";
}

const char* to_string(CrcStatus status) {
    switch (status) {
        case CrcStatus::kNotApplicable:
            return "not applicable";
        case CrcStatus::kAbsent:
            return "absent";
        case CrcStatus::kValid:
            return "valid";
        case CrcStatus::kInvalid:
            return "invalid";
    }
    return "unknown";
}

std::uint64_t crc64(const std::uint8_t* data, std::size_t size) {
    std::uint64_t c = ~0ULL;
    std::size_t i = 0;
    for (; i + 8 <= size; i += 8) {  // 8 bytes per step (little-endian load)
        std::uint64_t word = 0;
        std::memcpy(&word, data + i, 8);
        c ^= word;
        c = kCrcTables[7][c & 0xFFU] ^ kCrcTables[6][(c >> 8) & 0xFFU] ^
            kCrcTables[5][(c >> 16) & 0xFFU] ^ kCrcTables[4][(c >> 24) & 0xFFU] ^
            kCrcTables[3][(c >> 32) & 0xFFU] ^ kCrcTables[2][(c >> 40) & 0xFFU] ^
            kCrcTables[1][(c >> 48) & 0xFFU] ^ kCrcTables[0][c >> 56];
    }
    for (; i < size; ++i) c = kCrcTables[0][(c ^ data[i]) & 0xFFU] ^ (c >> 8);
    return ~c;
}

PacketFormat::PacketFormat(UdpProfileLidar profile, int pixels_per_column, int columns_per_packet)
    : layout_(&profile_layout(profile)),
      header_(&header_layout(layout_->header_type)),
      pixels_per_column_(pixels_per_column),
      columns_per_packet_(columns_per_packet) {
    if (pixels_per_column < 1 || pixels_per_column > 256) {
        throw std::invalid_argument("pixels_per_column must be in 1..256, got " +
                                    std::to_string(pixels_per_column));
    }
    if (columns_per_packet < 1 || columns_per_packet > 256) {
        throw std::invalid_argument("columns_per_packet must be in 1..256, got " +
                                    std::to_string(columns_per_packet));
    }
    packet_header_size_ = header_->packet_header_bytes;
    column_header_size_ = header_->column_header_bytes;
    packet_footer_size_ = header_->packet_footer_bytes;
    column_size_ = column_header_size_ +
                   static_cast<std::size_t>(pixels_per_column) * layout_->pixel_size_bytes +
                   header_->column_footer_bytes;
    packet_size_ = packet_header_size_ +
                   static_cast<std::size_t>(columns_per_packet) * column_size_ +
                   packet_footer_size_;
    if (packet_size_ > kMaxUdpPayload) {
        throw std::invalid_argument(
            std::string(to_string(profile)) + " with " + std::to_string(pixels_per_column) +
            " pixels x " + std::to_string(columns_per_packet) + " columns needs " +
            std::to_string(packet_size_) + " B, more than a UDP datagram holds (65507 B)");
    }
}

PacketFormat::PacketFormat(const SensorInfo& info)
    : PacketFormat(info.udp_profile_lidar, info.pixels_per_column, info.columns_per_packet) {
    expected_serial_ = info.serial_number() & 0xFFFFFFFFFFULL;
    columns_per_frame_ = info.columns_per_frame;
}

PacketKind PacketFormat::classify(const std::uint8_t* data, std::size_t size) const {
    if (size == kImuPacketSize) return PacketKind::kImu;
    if (size != packet_size_ || data == nullptr) return PacketKind::kWrongSize;
    switch (header_type()) {
        case HeaderType::kLegacy:
            if (columns_per_frame_ > 0 &&
                column_measurement_id(column(data, 0)) >= columns_per_frame_) {
                return PacketKind::kWrongProfile;
            }
            return PacketKind::kLidar;
        case HeaderType::kStandard:
        case HeaderType::kFusa:
            if (packet_type(data) != kLidarPacketType) return PacketKind::kWrongProfile;
            if (expected_serial_ != 0 && prod_sn(data) != expected_serial_) {
                return PacketKind::kWrongProfile;
            }
            return PacketKind::kLidar;
    }
    return PacketKind::kWrongProfile;
}

std::uint64_t PacketFormat::header_value(const std::uint8_t* pkt, HeaderField f) const {
    const HeaderFieldSpec& s = header_->fields[static_cast<int>(f)];
    return s.present() ? fetch(pkt + s.offset, s.bytes) & s.mask : 0;
}

std::uint64_t PacketFormat::column_value(const std::uint8_t* col, HeaderField f) const {
    const HeaderFieldSpec& s = header_->fields[static_cast<int>(f)];
    return s.present() ? fetch(col + column_offset(s), s.bytes) & s.mask : 0;
}

std::uint16_t PacketFormat::packet_type(const std::uint8_t* pkt) const {
    return static_cast<std::uint16_t>(header_value(pkt, HeaderField::kPacketType));
}

std::uint32_t PacketFormat::frame_id(const std::uint8_t* pkt) const {
    if (header_type() == HeaderType::kLegacy) return column_frame_id(column(pkt, 0));
    return static_cast<std::uint32_t>(header_value(pkt, HeaderField::kFrameId));
}

std::uint32_t PacketFormat::init_id(const std::uint8_t* pkt) const {
    return static_cast<std::uint32_t>(header_value(pkt, HeaderField::kInitId));
}

std::uint64_t PacketFormat::prod_sn(const std::uint8_t* pkt) const {
    return header_value(pkt, HeaderField::kProdSn);
}

std::uint8_t PacketFormat::alert_flags(const std::uint8_t* pkt) const {
    return static_cast<std::uint8_t>(header_value(pkt, HeaderField::kAlertFlags));
}

std::uint8_t PacketFormat::countdown_thermal_shutdown(const std::uint8_t* pkt) const {
    return static_cast<std::uint8_t>(header_value(pkt, HeaderField::kCountdownThermalShutdown));
}
std::uint8_t PacketFormat::countdown_shot_limiting(const std::uint8_t* pkt) const {
    return static_cast<std::uint8_t>(header_value(pkt, HeaderField::kCountdownShotLimiting));
}
std::uint8_t PacketFormat::thermal_shutdown(const std::uint8_t* pkt) const {
    return static_cast<std::uint8_t>(header_value(pkt, HeaderField::kThermalShutdown));
}
std::uint8_t PacketFormat::shot_limiting(const std::uint8_t* pkt) const {
    return static_cast<std::uint8_t>(header_value(pkt, HeaderField::kShotLimiting));
}

std::uint32_t PacketFormat::column_status(const std::uint8_t* col) const {
    return static_cast<std::uint32_t>(column_value(col, HeaderField::kColumnStatus));
}

std::uint16_t PacketFormat::column_frame_id(const std::uint8_t* col) const {
    return static_cast<std::uint16_t>(column_value(col, HeaderField::kColumnFrameId));
}

std::uint32_t PacketFormat::column_encoder_count(const std::uint8_t* col) const {
    return static_cast<std::uint32_t>(column_value(col, HeaderField::kColumnEncoderCount));
}

void PacketFormat::read_columns(const std::uint8_t* pkt, int first, int count, Field f,
                                std::uint32_t* dst, std::ptrdiff_t dst_stride) const {
    read_columns_impl(*this, pkt, first, count, f, dst, dst_stride);
}
void PacketFormat::read_columns(const std::uint8_t* pkt, int first, int count, Field f,
                                std::uint16_t* dst, std::ptrdiff_t dst_stride) const {
    read_columns_impl(*this, pkt, first, count, f, dst, dst_stride);
}
void PacketFormat::read_columns(const std::uint8_t* pkt, int first, int count, Field f,
                                std::uint8_t* dst, std::ptrdiff_t dst_stride) const {
    read_columns_impl(*this, pkt, first, count, f, dst, dst_stride);
}
void PacketFormat::read_column(const std::uint8_t* col, Field f, std::uint32_t* dst,
                               std::ptrdiff_t dst_stride) const {
    read_pixels(*this, col, 0, 1, f, dst, dst_stride);
}
void PacketFormat::read_column(const std::uint8_t* col, Field f, std::uint16_t* dst,
                               std::ptrdiff_t dst_stride) const {
    read_pixels(*this, col, 0, 1, f, dst, dst_stride);
}
void PacketFormat::read_column(const std::uint8_t* col, Field f, std::uint8_t* dst,
                               std::ptrdiff_t dst_stride) const {
    read_pixels(*this, col, 0, 1, f, dst, dst_stride);
}

std::uint64_t PacketFormat::stored_crc(const std::uint8_t* pkt) const {
    if (!has_crc()) return 0;
    return fetch(pkt + packet_size_ - 8, 8);
}

std::uint64_t PacketFormat::computed_crc(const std::uint8_t* pkt) const {
    if (!has_crc()) return 0;
    return crc64(pkt, packet_size_ - 8);
}

CrcStatus PacketFormat::check_crc(const std::uint8_t* pkt) const {
    if (!has_crc()) return CrcStatus::kNotApplicable;
    const std::uint64_t stored = stored_crc(pkt);
    if (stored == 0) return CrcStatus::kAbsent;
    return stored == computed_crc(pkt) ? CrcStatus::kValid : CrcStatus::kInvalid;
}

// --- writing ---

void PacketFormat::set_header_value(std::uint8_t* pkt, HeaderField f, std::uint64_t value) const {
    const HeaderFieldSpec& s = header_->fields[static_cast<int>(f)];
    if (s.present()) store_masked(pkt + s.offset, s, value);
}

void PacketFormat::set_column_value(std::uint8_t* col, HeaderField f, std::uint64_t value) const {
    const HeaderFieldSpec& s = header_->fields[static_cast<int>(f)];
    if (s.present()) store_masked(col + column_offset(s), s, value);
}

void PacketFormat::set_packet_type(std::uint8_t* pkt, std::uint16_t value) const {
    set_header_value(pkt, HeaderField::kPacketType, value);
}

void PacketFormat::set_frame_id(std::uint8_t* pkt, std::uint32_t value) const {
    if (header_type() != HeaderType::kLegacy) {
        set_header_value(pkt, HeaderField::kFrameId, value);
        return;
    }
    for (int c = 0; c < columns_per_packet_; ++c)
        set_column_frame_id(column(pkt, c), static_cast<std::uint16_t>(value));
}

void PacketFormat::set_init_id(std::uint8_t* pkt, std::uint32_t value) const {
    set_header_value(pkt, HeaderField::kInitId, value);
}

void PacketFormat::set_prod_sn(std::uint8_t* pkt, std::uint64_t value) const {
    set_header_value(pkt, HeaderField::kProdSn, value);
}

void PacketFormat::set_alert_flags(std::uint8_t* pkt, std::uint8_t value) const {
    set_header_value(pkt, HeaderField::kAlertFlags, value);
}

void PacketFormat::set_countdown_thermal_shutdown(std::uint8_t* pkt, std::uint8_t value) const {
    set_header_value(pkt, HeaderField::kCountdownThermalShutdown, value);
}
void PacketFormat::set_countdown_shot_limiting(std::uint8_t* pkt, std::uint8_t value) const {
    set_header_value(pkt, HeaderField::kCountdownShotLimiting, value);
}
void PacketFormat::set_thermal_shutdown(std::uint8_t* pkt, std::uint8_t value) const {
    set_header_value(pkt, HeaderField::kThermalShutdown, value);
}
void PacketFormat::set_shot_limiting(std::uint8_t* pkt, std::uint8_t value) const {
    set_header_value(pkt, HeaderField::kShotLimiting, value);
}

void PacketFormat::set_column_timestamp_ns(std::uint8_t* col, std::uint64_t value) const {
    set_column_value(col, HeaderField::kColumnTimestamp, value);
}
void PacketFormat::set_column_measurement_id(std::uint8_t* col, std::uint16_t value) const {
    set_column_value(col, HeaderField::kColumnMeasurementId, value);
}
void PacketFormat::set_column_status(std::uint8_t* col, std::uint32_t value) const {
    set_column_value(col, HeaderField::kColumnStatus, value);
}
void PacketFormat::set_column_frame_id(std::uint8_t* col, std::uint16_t value) const {
    set_column_value(col, HeaderField::kColumnFrameId, value);
}
void PacketFormat::set_column_encoder_count(std::uint8_t* col, std::uint32_t value) const {
    set_column_value(col, HeaderField::kColumnEncoderCount, value);
}

bool PacketFormat::set_field(std::uint8_t* px, Field f, std::uint32_t value) const {
    const FieldSpec& s = spec(f);
    if (!s.present()) return false;
    std::uint32_t word = 0;
    std::memcpy(&word, px + s.offset, s.bytes);
    word = (word & ~s.mask) | ((value >> s.upshift) & s.mask);
    std::memcpy(px + s.offset, &word, s.bytes);
    return true;
}

void PacketFormat::write_crc(std::uint8_t* pkt) const {
    if (!has_crc()) return;
    store(pkt + packet_size_ - 8, crc64(pkt, packet_size_ - 8), 8);
}

}  // namespace lidarfuse::ouster
