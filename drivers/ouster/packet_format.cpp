// The profile table and the header/footer accessors of PacketFormat.

#include "drivers/ouster/packet_format.hpp"

#include <array>
#include <stdexcept>
#include <string>

namespace lidarfuse::ouster {
namespace {

// Field order follows the Field enum: range, range2, signal, signal2, reflectivity,
// reflectivity2, near_ir. {offset, bytes, mask, upshift}; bytes 0 = absent.
constexpr FieldSpec kAbsent{0, 0, 0, 0};
constexpr ProfileLayout kLayouts[] = {
    {UdpProfileLidar::kLegacy,
     HeaderType::kLegacy,
     12,
     1,
     {{0, 4, 0xFFFFF, 0},
      kAbsent,
      {6, 2, 0xFFFF, 0},
      kAbsent,
      {4, 1, 0xFF, 0},
      kAbsent,
      {8, 2, 0xFFFF, 0}}},
    {UdpProfileLidar::kRng19Rfl8Sig16Nir16,
     HeaderType::kStandard,
     12,
     1,
     {{0, 4, 0x7FFFF, 0},
      kAbsent,
      {6, 2, 0xFFFF, 0},
      kAbsent,
      {4, 1, 0xFF, 0},
      kAbsent,
      {8, 2, 0xFFFF, 0}}},
    {UdpProfileLidar::kRng15Rfl8Nir8,
     HeaderType::kStandard,
     4,
     1,
     {{0, 2, 0x7FFF, 3}, kAbsent, kAbsent, kAbsent, {2, 1, 0xFF, 0}, kAbsent, {3, 1, 0xFF, 4}}},
    {UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
     HeaderType::kStandard,
     16,
     2,
     {{0, 4, 0x7FFFF, 0},
      {4, 4, 0x7FFFF, 0},
      {8, 2, 0xFFFF, 0},
      {10, 2, 0xFFFF, 0},
      {3, 1, 0xFF, 0},
      {7, 1, 0xFF, 0},
      {12, 2, 0xFFFF, 0}}},
    {UdpProfileLidar::kFusaRng15Rfl8Nir8Dual,
     HeaderType::kFusa,
     8,
     2,
     {{0, 2, 0x7FFF, 3},
      {4, 2, 0x7FFF, 3},
      kAbsent,
      kAbsent,
      {2, 1, 0xFF, 0},
      {6, 1, 0xFF, 0},
      {3, 1, 0xFF, 4}}},
};

constexpr std::size_t kMaxUdpPayload = 65507;
constexpr std::size_t kStandardHeaderSize = 32;
constexpr std::size_t kStandardFooterSize = 32;
constexpr std::size_t kLegacyColumnHeaderSize = 16;
constexpr std::size_t kLegacyColumnFooterSize = 4;
constexpr std::size_t kColumnHeaderSize = 12;

// Header field offsets: STANDARD / FUSA.
constexpr std::size_t kInitIdOffset[] = {4, 1};
constexpr std::size_t kProdSnOffset[] = {7, 11};
constexpr std::size_t kAlertFlagsOffset[] = {12, 8};

void store(std::uint8_t* p, std::uint64_t value, std::size_t bytes) {
    std::memcpy(p, &value, bytes);  // little-endian host
}

std::uint64_t fetch(const std::uint8_t* p, std::size_t bytes) {
    std::uint64_t v = 0;
    std::memcpy(&v, p, bytes);
    return v;
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

// Fixed-width loads keep the per-pixel memcpy inlined (a runtime size would be a call).
template <std::size_t N, typename T>
void read_column_n(const std::uint8_t* px, std::size_t step, int rows, const FieldSpec& s, T* dst,
                   std::ptrdiff_t stride) {
    for (int row = 0; row < rows; ++row, px += step, dst += stride) {
        std::uint32_t v = 0;
        std::memcpy(&v, px, N);
        *dst = static_cast<T>((v & s.mask) << s.upshift);
    }
}

template <typename T>
void read_column_impl(const PacketFormat& f, const std::uint8_t* col, Field field, T* dst,
                      std::ptrdiff_t stride) {
    const FieldSpec s = f.spec(field);
    const std::uint8_t* px = f.pixel(col, 0) + s.offset;
    const std::size_t step = f.pixel_size();
    const int rows = f.pixels_per_column();
    switch (s.bytes) {
        case 1:
            read_column_n<1>(px, step, rows, s, dst, stride);
            break;
        case 2:
            read_column_n<2>(px, step, rows, s, dst, stride);
            break;
        case 4:
            read_column_n<4>(px, step, rows, s, dst, stride);
            break;
        default:
            break;  // absent field
    }
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

const ProfileLayout& profile_layout(UdpProfileLidar profile) {
    for (const ProfileLayout& l : kLayouts) {
        if (l.profile == profile) return l;
    }
    return kLayouts[0];
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
    const bool legacy = layout_->header_type == HeaderType::kLegacy;
    packet_header_size_ = legacy ? 0 : kStandardHeaderSize;
    column_header_size_ = legacy ? kLegacyColumnHeaderSize : kColumnHeaderSize;
    packet_footer_size_ = legacy ? 0 : kStandardFooterSize;
    column_size_ = column_header_size_ +
                   static_cast<std::size_t>(pixels_per_column) * layout_->pixel_size_bytes +
                   (legacy ? kLegacyColumnFooterSize : 0);
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

std::uint16_t PacketFormat::packet_type(const std::uint8_t* pkt) const {
    switch (header_type()) {
        case HeaderType::kLegacy:
            return 0;
        case HeaderType::kStandard:
            return static_cast<std::uint16_t>(fetch(pkt, 2));
        case HeaderType::kFusa:
            return pkt[0];
    }
    return 0;
}

std::uint32_t PacketFormat::frame_id(const std::uint8_t* pkt) const {
    switch (header_type()) {
        case HeaderType::kLegacy:
            return column_frame_id(column(pkt, 0));
        case HeaderType::kStandard:
            return static_cast<std::uint32_t>(fetch(pkt + 2, 2));
        case HeaderType::kFusa:
            return static_cast<std::uint32_t>(fetch(pkt + 4, 4));
    }
    return 0;
}

std::uint32_t PacketFormat::init_id(const std::uint8_t* pkt) const {
    if (header_type() == HeaderType::kLegacy) return 0;
    const int k = header_type() == HeaderType::kFusa ? 1 : 0;
    return static_cast<std::uint32_t>(fetch(pkt + kInitIdOffset[k], 3));
}

std::uint64_t PacketFormat::prod_sn(const std::uint8_t* pkt) const {
    if (header_type() == HeaderType::kLegacy) return 0;
    const int k = header_type() == HeaderType::kFusa ? 1 : 0;
    return fetch(pkt + kProdSnOffset[k], 5);
}

std::uint8_t PacketFormat::alert_flags(const std::uint8_t* pkt) const {
    if (header_type() == HeaderType::kLegacy) return 0;
    return pkt[kAlertFlagsOffset[header_type() == HeaderType::kFusa ? 1 : 0]];
}

std::uint8_t PacketFormat::countdown_thermal_shutdown(const std::uint8_t* pkt) const {
    return header_type() == HeaderType::kLegacy ? 0 : pkt[16];
}
std::uint8_t PacketFormat::countdown_shot_limiting(const std::uint8_t* pkt) const {
    return header_type() == HeaderType::kLegacy ? 0 : pkt[17];
}
std::uint8_t PacketFormat::thermal_shutdown(const std::uint8_t* pkt) const {
    return header_type() == HeaderType::kLegacy ? 0 : static_cast<std::uint8_t>(pkt[18] & 0x0F);
}
std::uint8_t PacketFormat::shot_limiting(const std::uint8_t* pkt) const {
    return header_type() == HeaderType::kLegacy ? 0 : static_cast<std::uint8_t>(pkt[19] & 0x0F);
}

std::uint32_t PacketFormat::column_status(const std::uint8_t* col) const {
    if (header_type() == HeaderType::kLegacy) {
        return static_cast<std::uint32_t>(fetch(col + column_size_ - kLegacyColumnFooterSize, 4));
    }
    return static_cast<std::uint32_t>(fetch(col + 10, 2));
}

std::uint16_t PacketFormat::column_frame_id(const std::uint8_t* col) const {
    return header_type() == HeaderType::kLegacy ? static_cast<std::uint16_t>(fetch(col + 10, 2))
                                                : 0;
}

std::uint32_t PacketFormat::column_encoder_count(const std::uint8_t* col) const {
    return header_type() == HeaderType::kLegacy ? static_cast<std::uint32_t>(fetch(col + 12, 4))
                                                : 0;
}

void PacketFormat::read_column(const std::uint8_t* col, Field f, std::uint32_t* dst,
                               std::ptrdiff_t dst_stride) const {
    read_column_impl(*this, col, f, dst, dst_stride);
}
void PacketFormat::read_column(const std::uint8_t* col, Field f, std::uint16_t* dst,
                               std::ptrdiff_t dst_stride) const {
    read_column_impl(*this, col, f, dst, dst_stride);
}
void PacketFormat::read_column(const std::uint8_t* col, Field f, std::uint8_t* dst,
                               std::ptrdiff_t dst_stride) const {
    read_column_impl(*this, col, f, dst, dst_stride);
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

void PacketFormat::set_packet_type(std::uint8_t* pkt, std::uint16_t value) const {
    if (header_type() == HeaderType::kStandard) store(pkt, value, 2);
    if (header_type() == HeaderType::kFusa) pkt[0] = static_cast<std::uint8_t>(value);
}

void PacketFormat::set_frame_id(std::uint8_t* pkt, std::uint32_t value) const {
    switch (header_type()) {
        case HeaderType::kLegacy:
            for (int c = 0; c < columns_per_packet_; ++c) {
                set_column_frame_id(column(pkt, c), static_cast<std::uint16_t>(value));
            }
            break;
        case HeaderType::kStandard:
            store(pkt + 2, value & 0xFFFFU, 2);
            break;
        case HeaderType::kFusa:
            store(pkt + 4, value, 4);
            break;
    }
}

void PacketFormat::set_init_id(std::uint8_t* pkt, std::uint32_t value) const {
    if (header_type() == HeaderType::kLegacy) return;
    const int k = header_type() == HeaderType::kFusa ? 1 : 0;
    store(pkt + kInitIdOffset[k], value & 0xFFFFFFU, 3);
}

void PacketFormat::set_prod_sn(std::uint8_t* pkt, std::uint64_t value) const {
    if (header_type() == HeaderType::kLegacy) return;
    const int k = header_type() == HeaderType::kFusa ? 1 : 0;
    store(pkt + kProdSnOffset[k], value & 0xFFFFFFFFFFULL, 5);
}

void PacketFormat::set_alert_flags(std::uint8_t* pkt, std::uint8_t value) const {
    if (header_type() == HeaderType::kLegacy) return;
    pkt[kAlertFlagsOffset[header_type() == HeaderType::kFusa ? 1 : 0]] = value;
}

void PacketFormat::set_countdown_thermal_shutdown(std::uint8_t* pkt, std::uint8_t value) const {
    if (header_type() != HeaderType::kLegacy) pkt[16] = value;
}
void PacketFormat::set_countdown_shot_limiting(std::uint8_t* pkt, std::uint8_t value) const {
    if (header_type() != HeaderType::kLegacy) pkt[17] = value;
}
void PacketFormat::set_thermal_shutdown(std::uint8_t* pkt, std::uint8_t value) const {
    if (header_type() != HeaderType::kLegacy) {
        pkt[18] = static_cast<std::uint8_t>((pkt[18] & 0xF0) | (value & 0x0F));
    }
}
void PacketFormat::set_shot_limiting(std::uint8_t* pkt, std::uint8_t value) const {
    if (header_type() != HeaderType::kLegacy) {
        pkt[19] = static_cast<std::uint8_t>((pkt[19] & 0xF0) | (value & 0x0F));
    }
}

void PacketFormat::set_column_timestamp_ns(std::uint8_t* col, std::uint64_t value) const {
    store(col, value, 8);
}
void PacketFormat::set_column_measurement_id(std::uint8_t* col, std::uint16_t value) const {
    store(col + 8, value, 2);
}
void PacketFormat::set_column_status(std::uint8_t* col, std::uint32_t value) const {
    if (header_type() == HeaderType::kLegacy) {
        store(col + column_size_ - kLegacyColumnFooterSize, value, 4);
    } else {
        store(col + 10, value & 0xFFFFU, 2);
    }
}
void PacketFormat::set_column_frame_id(std::uint8_t* col, std::uint16_t value) const {
    if (header_type() == HeaderType::kLegacy) store(col + 10, value, 2);
}
void PacketFormat::set_column_encoder_count(std::uint8_t* col, std::uint32_t value) const {
    if (header_type() == HeaderType::kLegacy) store(col + 12, value, 4);
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
