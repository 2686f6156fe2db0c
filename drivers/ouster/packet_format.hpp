#pragma once
// Ouster UDP lidar packet layout, driven by two tables: header fields per header type and
// pixel fields per profile, each used for reading and for writing. Reads and writes work on raw
// `uint8_t*` buffers with memcpy (little endian on the wire, no alignment assumptions); nothing
// here allocates or throws after construction, so the per-packet path is safe for the real-time
// ingest threads. A PacketFormat is immutable and may be shared between threads.
//
// Packet = [packet header] + columns_per_packet x column + [packet footer]
//   LEGACY header type:   no packet header; column = 16 B header (timestamp u64,
//                         measurement_id u16, frame_id u16, encoder_count u32) + pixels +
//                         4 B footer (status u32, 0xFFFFFFFF when valid); no packet footer.
//   STANDARD header type: 32 B packet header (packet_type u16 @0, frame_id u16 @2,
//                         init_id u24 @4, prod_sn u40 @7, alert_flags u8 @12 (FW 2.5+),
//                         countdown_thermal_shutdown u8
//                         @16, countdown_shot_limiting u8 @17, thermal_shutdown u4 @18,
//                         shot_limiting u4 @19); column = 12 B header (timestamp u64,
//                         measurement_id u16, status u16, bit 0 = valid) + pixels;
//                         32 B packet footer whose last 8 B hold a CRC-64 (filled by
//                         FW 2.5+ in the sample captures; zero on older firmware).
//   FUSA header type:     as STANDARD except packet_type u8 @0, init_id u24 @1,
//                         frame_id u32 @4, alert_flags u8 @8, prod_sn u40 @11.
// Pixel fields (values returned after masking and the profile's upshift):
//   LEGACY        12 B: range u20 @0, reflectivity @4 (low byte), signal u16 @6, nir u16 @8
//   RNG19 single  12 B: range u19 @0, reflectivity u8 @4, signal u16 @6, nir u16 @8
//   RNG15 lowdata  4 B: range u15 @0 x8, reflectivity u8 @2, nir u8 @3 x16
//   RNG19 dual    16 B: range u19 @0, refl u8 @3, range2 u19 @4, refl2 u8 @7,
//                       signal u16 @8, signal2 u16 @10, nir u16 @12
//   FUSA dual      8 B: range u15 @0 x8, refl u8 @2, nir u8 @3 x16, range2 u15 @4 x8,
//                       refl2 u8 @6
// Units: ranges in millimetres, timestamps in nanoseconds (sensor clock as configured by
// timestamp_mode), signal/near_ir in photon counts.

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::ouster {

enum class HeaderType : std::uint8_t { kLegacy, kStandard, kFusa };

// Per-pixel channels. Not every profile has every field (see PacketFormat::has_field).
enum class Field : std::uint8_t {
    kRange,   // mm, first return
    kRange2,  // mm, second return (dual profiles)
    kSignal,  // photons
    kSignal2,
    kReflectivity,  // calibrated reflectivity 0..255
    kReflectivity2,
    kNearIr,  // photons (low-data profiles: after x16 upshift)
};
constexpr int kFieldCount = 7;
const char* to_string(Field field);

// Where one field sits inside a pixel: `bytes` (1, 2 or 4; 0 = absent) read at `offset`,
// AND `mask`, then shifted left by `upshift` bits to reach the documented unit.
struct FieldSpec {
    std::uint8_t offset = 0;
    std::uint8_t bytes = 0;
    std::uint32_t mask = 0;
    std::uint8_t upshift = 0;
    bool present() const { return bytes != 0; }
};

// One row of the data-driven table.
struct ProfileLayout {
    UdpProfileLidar profile;
    HeaderType header_type;
    std::uint8_t pixel_size_bytes;
    std::uint8_t returns;  // 1 or 2
    FieldSpec fields[kFieldCount];
};

// The table entry of a profile (static storage, never null).
const ProfileLayout& profile_layout(UdpProfileLidar profile);

// Fields of the packet header, then of each column's header (or footer).
enum class HeaderField : std::uint8_t {
    kPacketType,
    kFrameId,  // LEGACY: in every column header (kColumnFrameId)
    kInitId,
    kProdSn,
    kAlertFlags,
    kCountdownThermalShutdown,
    kCountdownShotLimiting,
    kThermalShutdown,
    kShotLimiting,
    kColumnTimestamp,  // ns
    kColumnMeasurementId,
    kColumnStatus,
    kColumnFrameId,       // LEGACY
    kColumnEncoderCount,  // LEGACY, 90112 ticks per turn
};
constexpr int kHeaderFieldCount = 14;

// Where one header field sits: `bytes` (0 = absent) at `offset` from the packet's start
// (column fields: from the column's start, or from the column footer's start when
// `in_column_footer`); its value is the bits of `mask`. Writing keeps the other bits.
struct HeaderFieldSpec {
    std::uint8_t offset = 0;
    std::uint8_t bytes = 0;
    std::uint64_t mask = 0;
    bool in_column_footer = false;
    bool present() const { return bytes != 0; }
};

// One row of the header table: the sizes around the pixels and every header field.
struct HeaderLayout {
    HeaderType type;
    std::uint8_t packet_header_bytes;
    std::uint8_t column_header_bytes;
    std::uint8_t column_footer_bytes;
    std::uint8_t packet_footer_bytes;  // its last 8 B hold the CRC-64
    HeaderFieldSpec fields[kHeaderFieldCount];
};

// The table entry of a header type (static storage).
const HeaderLayout& header_layout(HeaderType type);

// What a datagram is, judged by its size and (non-legacy) header.
enum class PacketKind : std::uint8_t {
    kLidar,         // lidar packet of this format
    kImu,           // 48 B IMU packet (recognised, carries no lidar data)
    kWrongSize,     // neither the lidar nor the IMU size of this format
    kWrongProfile,  // lidar size matches but the header says another profile/sensor type
};
const char* to_string(PacketKind kind);

enum class CrcStatus : std::uint8_t {
    kNotApplicable,  // LEGACY: no packet footer
    kAbsent,         // footer CRC field is zero (firmware before 3.0 does not fill it)
    kValid,
    kInvalid,
};
const char* to_string(CrcStatus status);

// CRC-64 used in Ouster packet footers: CRC-64/XZ (ECMA-182 polynomial 0x42F0E1EBA9EA3693,
// reflected, init and final XOR 0xFFFFFFFFFFFFFFFF; check("123456789") =
// 0x995DC9BBDF1939FA), computed over the packet up to (excluding) the CRC's 8 bytes.
std::uint64_t crc64(const std::uint8_t* data, std::size_t size);

class PacketFormat {
public:
    static constexpr std::size_t kImuPacketSize = 48;

    // Throws std::invalid_argument for pixels_per_column / columns_per_packet outside
    // 1..256 or a packet larger than 65,507 B (the UDP payload limit).
    PacketFormat(UdpProfileLidar profile, int pixels_per_column, int columns_per_packet);
    explicit PacketFormat(const SensorInfo& info);

    // --- layout ---
    UdpProfileLidar profile() const { return layout_->profile; }
    HeaderType header_type() const { return layout_->header_type; }
    const ProfileLayout& layout() const { return *layout_; }
    int pixels_per_column() const { return pixels_per_column_; }
    int columns_per_packet() const { return columns_per_packet_; }
    std::size_t lidar_packet_size() const { return packet_size_; }
    std::size_t imu_packet_size() const { return kImuPacketSize; }
    std::size_t packet_header_size() const { return packet_header_size_; }
    std::size_t column_header_size() const { return column_header_size_; }
    std::size_t column_size() const { return column_size_; }
    std::size_t pixel_size() const { return layout_->pixel_size_bytes; }
    std::size_t packet_footer_size() const { return packet_footer_size_; }
    bool has_field(Field f) const { return spec(f).present(); }
    const FieldSpec& spec(Field f) const { return layout_->fields[static_cast<int>(f)]; }
    bool has_crc() const { return header_type() != HeaderType::kLegacy; }

    // Size checks; for non-legacy formats also the packet_type (0x1 for lidar data) and,
    // when an expected serial is known (from SensorInfo or set_expected_serial), the header
    // prod_sn; for LEGACY that column 0's measurement_id is below columns_per_frame (when
    // known). A STANDARD and a FUSA packet can have the same size (16,640 B): the
    // STANDARD u16 packet_type rejects FUSA packets, and the serial check rejects STANDARD
    // packets read as FUSA.
    PacketKind classify(const std::uint8_t* data, std::size_t size) const;
    // 40-bit serial the header must carry for classify() to accept it; 0 = do not check.
    void set_expected_serial(std::uint64_t serial) { expected_serial_ = serial; }

    // --- packet header (all need a full lidar packet) ---
    // LEGACY: 0 (no packet header).
    std::uint16_t packet_type(const std::uint8_t* pkt) const;
    // LEGACY: the frame_id of column 0. STANDARD: 16 bit. FUSA: 32 bit.
    std::uint32_t frame_id(const std::uint8_t* pkt) const;
    // 24-bit initialization id; LEGACY: 0.
    std::uint32_t init_id(const std::uint8_t* pkt) const;
    // 40-bit serial number; LEGACY: 0.
    std::uint64_t prod_sn(const std::uint8_t* pkt) const;
    // Alert flags byte (FW 2.5+; 0 on older firmware); LEGACY: 0.
    std::uint8_t alert_flags(const std::uint8_t* pkt) const;
    std::uint8_t countdown_thermal_shutdown(const std::uint8_t* pkt) const;
    std::uint8_t countdown_shot_limiting(const std::uint8_t* pkt) const;
    std::uint8_t thermal_shutdown(const std::uint8_t* pkt) const;
    std::uint8_t shot_limiting(const std::uint8_t* pkt) const;

    // --- columns ---
    const std::uint8_t* column(const std::uint8_t* pkt, int index) const {
        return pkt + packet_header_size_ + static_cast<std::size_t>(index) * column_size_;
    }
    std::uint8_t* column(std::uint8_t* pkt, int index) const {
        return pkt + packet_header_size_ + static_cast<std::size_t>(index) * column_size_;
    }
    std::uint64_t column_timestamp_ns(const std::uint8_t* col) const {
        return column_value(col, HeaderField::kColumnTimestamp);
    }
    std::uint16_t column_measurement_id(const std::uint8_t* col) const {
        return static_cast<std::uint16_t>(column_value(col, HeaderField::kColumnMeasurementId));
    }
    // LEGACY: the 32-bit footer word (0xFFFFFFFF valid). Others: the 16-bit status.
    std::uint32_t column_status(const std::uint8_t* col) const;
    // Bit 0 of the status: the column holds a measurement (LEGACY: all bits set).
    bool column_valid(const std::uint8_t* col) const { return (column_status(col) & 1U) != 0; }
    // LEGACY only (0 otherwise): per-column frame id and encoder count (90112 ticks/turn).
    std::uint16_t column_frame_id(const std::uint8_t* col) const;
    std::uint32_t column_encoder_count(const std::uint8_t* col) const;

    // --- pixels ---
    const std::uint8_t* pixel(const std::uint8_t* col, int row) const {
        return col + column_header_size_ + static_cast<std::size_t>(row) * pixel_size();
    }
    std::uint8_t* pixel(std::uint8_t* col, int row) const {
        return col + column_header_size_ + static_cast<std::size_t>(row) * pixel_size();
    }
    // Value after mask and upshift; 0 for a field the profile does not have.
    std::uint32_t field(const std::uint8_t* px, Field f) const {
        const FieldSpec& s = spec(f);
        return ((read_bytes(px + s.offset, s.bytes) & s.mask) << s.upshift);
    }
    std::uint32_t range_mm(const std::uint8_t* px) const { return field(px, Field::kRange); }
    std::uint32_t range2_mm(const std::uint8_t* px) const { return field(px, Field::kRange2); }
    std::uint16_t signal(const std::uint8_t* px) const {
        return static_cast<std::uint16_t>(field(px, Field::kSignal));
    }
    std::uint16_t signal2(const std::uint8_t* px) const {
        return static_cast<std::uint16_t>(field(px, Field::kSignal2));
    }
    std::uint8_t reflectivity(const std::uint8_t* px) const {
        return static_cast<std::uint8_t>(field(px, Field::kReflectivity));
    }
    std::uint8_t reflectivity2(const std::uint8_t* px) const {
        return static_cast<std::uint8_t>(field(px, Field::kReflectivity2));
    }
    std::uint16_t near_ir(const std::uint8_t* px) const {
        return static_cast<std::uint16_t>(field(px, Field::kNearIr));
    }
    // All pixels of one column for one field: dst[row * dst_stride] = value. Values wider
    // than the destination type are truncated (use u32 for ranges). No-op for absent fields.
    void read_column(const std::uint8_t* col, Field f, std::uint32_t* dst,
                     std::ptrdiff_t dst_stride) const;
    void read_column(const std::uint8_t* col, Field f, std::uint16_t* dst,
                     std::ptrdiff_t dst_stride) const;
    void read_column(const std::uint8_t* col, Field f, std::uint8_t* dst,
                     std::ptrdiff_t dst_stride) const;
    // The same for `count` consecutive columns of a packet from column `first`:
    // dst[row * dst_stride + c] = the value of column first + c. Row by row, so that each
    // row's writes are contiguous; a column at a time writes one row-major image row per
    // pixel, dst_stride apart (a cache line and often a page each).
    void read_columns(const std::uint8_t* pkt, int first, int count, Field f, std::uint32_t* dst,
                      std::ptrdiff_t dst_stride) const;
    void read_columns(const std::uint8_t* pkt, int first, int count, Field f, std::uint16_t* dst,
                      std::ptrdiff_t dst_stride) const;
    void read_columns(const std::uint8_t* pkt, int first, int count, Field f, std::uint8_t* dst,
                      std::ptrdiff_t dst_stride) const;

    // --- CRC-64 footer (STANDARD and FUSA) ---
    std::uint64_t stored_crc(const std::uint8_t* pkt) const;
    std::uint64_t computed_crc(const std::uint8_t* pkt) const;
    CrcStatus check_crc(const std::uint8_t* pkt) const;

    // --- writing (the simulator's encoder; same table as the reader) ---
    // Header setters are no-ops where the header type has no such field. For LEGACY,
    // set_frame_id writes the frame id into every column header.
    void set_packet_type(std::uint8_t* pkt, std::uint16_t value) const;
    void set_frame_id(std::uint8_t* pkt, std::uint32_t value) const;
    void set_init_id(std::uint8_t* pkt, std::uint32_t value) const;
    void set_prod_sn(std::uint8_t* pkt, std::uint64_t value) const;
    void set_alert_flags(std::uint8_t* pkt, std::uint8_t value) const;
    void set_countdown_thermal_shutdown(std::uint8_t* pkt, std::uint8_t value) const;
    void set_countdown_shot_limiting(std::uint8_t* pkt, std::uint8_t value) const;
    void set_thermal_shutdown(std::uint8_t* pkt, std::uint8_t value) const;
    void set_shot_limiting(std::uint8_t* pkt, std::uint8_t value) const;
    void set_column_timestamp_ns(std::uint8_t* col, std::uint64_t value) const;
    void set_column_measurement_id(std::uint8_t* col, std::uint16_t value) const;
    void set_column_status(std::uint8_t* col, std::uint32_t value) const;
    void set_column_frame_id(std::uint8_t* col, std::uint16_t value) const;       // LEGACY
    void set_column_encoder_count(std::uint8_t* col, std::uint32_t value) const;  // LEGACY
    // Stores `value` (in the reader's units) with the profile's downshift and mask; bits of
    // neighboring fields sharing the bytes are preserved. Values that do not fit are
    // truncated to the field width (range 0x7FFF x8 mm for RNG15). Returns false (and
    // writes nothing) for a field the profile does not have.
    bool set_field(std::uint8_t* px, Field f, std::uint32_t value) const;
    // Computes the CRC-64 over the packet and stores it in the footer (no-op for LEGACY).
    void write_crc(std::uint8_t* pkt) const;
    // Packet types in non-legacy headers.
    static constexpr std::uint16_t kLidarPacketType = 0x1;

private:
    // A header field's value; 0 where the header type has no such field.
    std::uint64_t header_value(const std::uint8_t* pkt, HeaderField f) const;
    std::uint64_t column_value(const std::uint8_t* col, HeaderField f) const;
    // Stores the value's masked bits; no-op where the header type has no such field.
    void set_header_value(std::uint8_t* pkt, HeaderField f, std::uint64_t value) const;
    void set_column_value(std::uint8_t* col, HeaderField f, std::uint64_t value) const;
    // Byte offset of a column field from the column's start.
    std::size_t column_offset(const HeaderFieldSpec& s) const {
        return s.in_column_footer ? column_size_ - header_->column_footer_bytes + s.offset
                                  : s.offset;
    }
    static std::uint32_t read_bytes(const std::uint8_t* p, std::uint8_t bytes) {
        std::uint32_t v = 0;
        switch (bytes) {
            case 1:
                v = *p;
                break;
            case 2: {
                std::uint16_t t;
                std::memcpy(&t, p, 2);
                v = t;
                break;
            }
            case 4:
                std::memcpy(&v, p, 4);
                break;
            default:
                break;
        }
        return v;
    }

    const ProfileLayout* layout_;
    const HeaderLayout* header_;
    int pixels_per_column_;
    int columns_per_packet_;
    std::size_t packet_header_size_;
    std::size_t column_header_size_;
    std::size_t column_size_;
    std::size_t packet_footer_size_;
    std::size_t packet_size_;
    std::uint64_t expected_serial_ = 0;
    int columns_per_frame_ = 0;  // 0 = unknown (no measurement_id check)
};

}  // namespace lidarfuse::ouster
