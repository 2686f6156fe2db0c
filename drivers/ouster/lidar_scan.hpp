#pragma once
// One frame (one rotation, one Ouster frame_id) of one sensor, as staggered field arrays.
//
// Layout: every pixel field is row-major H x W in the order the sensor measured it
// (STAGGERED, not destaggered): element [row * W + col] is beam `row` of the column whose
// measurement_id is `col`. This is exactly the byte order of Ouster's digest convention
// (md5 of the raw little-endian array), so a scan can be hashed without reshuffling.
// Units: range in mm after the profile's upshift (RNG15 x8), near_ir after its upshift
// (NIR8 x16); signal and reflectivity are raw counts. Per-column timestamp in ns of the
// sensor clock (whatever time source the sensor is set to).
//
// Buffers are allocated once by the constructor; reset() clears them in place, so a scan
// can be reused for every frame without touching the heap (the assembler relies on this).
// Fields the packet profile does not carry are empty vectors (see has()).
// Not thread safe; a scan is owned by one thread at a time.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace lidarfuse::ouster {

// Pixel fields a LidarScan can hold. A bit set of them says what a profile carries.
enum class ScanField : std::uint8_t {
    kRange = 0,
    kRange2,
    kSignal,
    kSignal2,
    kReflectivity,
    kReflectivity2,
    kNearIr,
};
constexpr std::uint32_t field_bit(ScanField f) { return 1u << static_cast<unsigned>(f); }
// Ouster's upper-case field name ("RANGE", "SIGNAL2", ...), as used in the digest files.
const char* field_name(ScanField f);
constexpr ScanField kAllScanFields[] = {
    ScanField::kRange,        ScanField::kRange2,        ScanField::kSignal, ScanField::kSignal2,
    ScanField::kReflectivity, ScanField::kReflectivity2, ScanField::kNearIr};

// Inclusive range of measurement ids (columns) the sensor fills with data: Ouster's
// column_window [first, last]. first > last means the window wraps through column 0
// (e.g. [370, 85] on a 512-column sensor covers 370..511 and 0..85).
struct ColumnWindow {
    std::uint32_t first = 0;
    std::uint32_t last = 0;
    bool contains(std::uint32_t col) const {
        return first <= last ? (col >= first && col <= last) : (col >= first || col <= last);
    }
    // Number of columns inside the window, given the scan width.
    std::size_t size(std::size_t width) const;
};

struct LidarScanLayout {
    std::size_t rows = 0;                                 // pixels_per_column (H)
    std::size_t columns = 0;                              // columns_per_frame (W)
    std::uint32_t fields = field_bit(ScanField::kRange);  // bit set of field_bit()
    // Columns the sensor fills; nullopt means the whole frame [0, columns - 1].
    std::optional<ColumnWindow> column_window;
};

class LidarScan {
public:
    LidarScan() = default;
    // Allocates every buffer; throws std::invalid_argument on a zero size or a column
    // window outside [0, columns).
    explicit LidarScan(const LidarScanLayout& layout);

    // Zeroes every array and header value in place (no reallocation).
    void reset();

    const LidarScanLayout& layout() const { return layout_; }
    std::size_t rows() const { return layout_.rows; }
    std::size_t columns() const { return layout_.columns; }
    bool has(ScanField f) const { return (layout_.fields & field_bit(f)) != 0; }

    // Raw bytes of a pixel field array (empty when the profile lacks the field), for
    // hashing and export.
    const void* field_data(ScanField f) const;
    std::size_t field_bytes(ScanField f) const;

    // Columns the window says the sensor fills, and how many of those arrived.
    std::size_t expected_columns() const { return expected_columns_; }
    std::size_t received_expected_columns() const { return received_expected_; }
    // received expected columns / expected columns, in [0, 1].
    double completeness() const;
    bool complete() const { return received_expected_ == expected_columns_; }
    // The layout's window, or the whole frame.
    const ColumnWindow& column_window() const { return window_; }

    // Marks column `col` received. Returns false (and changes nothing) when it already
    // was (a duplicate) or is out of range.
    bool mark_received(std::size_t col);

    // Pixel fields, H x W staggered, row-major.
    std::vector<std::uint32_t> range_mm;
    std::vector<std::uint32_t> range2_mm;
    std::vector<std::uint16_t> signal;
    std::vector<std::uint16_t> signal2;
    std::vector<std::uint8_t> reflectivity;
    std::vector<std::uint8_t> reflectivity2;
    std::vector<std::uint16_t> near_ir;

    // Column fields, W each, indexed by measurement_id.
    std::vector<std::uint64_t> timestamp_ns;
    std::vector<std::uint16_t> measurement_id;
    std::vector<std::uint64_t> status;   // widened from u16 (u32 in LEGACY)
    std::vector<std::uint8_t> received;  // 1 when a packet delivered this column

    // Header values of the packets that built this frame.
    std::uint32_t frame_id = 0;  // 16-bit on STANDARD/LEGACY headers, 32-bit on FUSA
    std::uint32_t init_id = 0;   // 0 for LEGACY (no such field)
    std::uint64_t serial = 0;    // prod_sn; 0 for LEGACY
    std::uint32_t packets = 0;   // lidar packets that contributed at least one column
    std::uint32_t duplicate_columns = 0;
    std::uint32_t bad_columns = 0;  // columns whose measurement_id was >= columns()

private:
    LidarScanLayout layout_;
    ColumnWindow window_;
    std::size_t expected_columns_ = 0;
    std::size_t received_expected_ = 0;
};

// One array of a scan as raw bytes, named as in Ouster's digest files.
struct ScanArrayView {
    const char* name;  // "RANGE", ..., "TIMESTAMP", "MEASUREMENT_ID", "STATUS"
    const void* data;
    std::size_t bytes;
};

// The arrays of Ouster's digest convention (SOURCES.md): every pixel field the scan has,
// in ScanField order, then TIMESTAMP (u64[W]), MEASUREMENT_ID (u16[W]) and STATUS
// (u64[W]). Bytes are the host's little-endian representation, as the digests expect.
std::vector<ScanArrayView> digest_arrays(const LidarScan& scan);

}  // namespace lidarfuse::ouster
