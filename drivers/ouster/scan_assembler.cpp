#include "drivers/ouster/scan_assembler.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace lidarfuse::ouster {

namespace {

// Footer word of firmware that does not compute the CRC-64 (seen in the FW 2.3 and 2.4
// sample captures: bytes de c0 00 00 ef be ad de).
constexpr std::uint64_t kUnfilledCrcMarker = 0xDEADBEEF0000C0DEull;

FrameWindowParams window_params(const ScanAssemblerParams& params, const PacketFormat& format) {
    FrameWindowParams p = params.window;
    p.frame_id_bits = format.header_type() == HeaderType::kFusa ? 32 : 16;
    return p;
}

ModeExpectation mode_expectation(const SensorInfo& info, const PacketFormat& format) {
    ModeExpectation e;
    e.columns_per_frame = static_cast<std::uint32_t>(std::max(0, info.columns_per_frame));
    e.frames_per_second = info.frames_per_second;
    e.lidar_packet_bytes = format.lidar_packet_size();
    e.packets_per_frame =
        format.columns_per_packet() > 0
            ? e.columns_per_frame / static_cast<std::uint32_t>(format.columns_per_packet())
            : 0;
    e.lidar_mode = info.lidar_mode;
    e.profile = to_string(info.udp_profile_lidar);
    return e;
}

}  // namespace

const char* to_string(PacketOutcome outcome) {
    switch (outcome) {
        case PacketOutcome::kAssembled:
            return "assembled";
        case PacketOutcome::kImu:
            return "imu";
        case PacketOutcome::kWrongSize:
            return "wrong_size";
        case PacketOutcome::kWrongProfile:
            return "wrong_profile";
        case PacketOutcome::kCrcError:
            return "crc_error";
        case PacketOutcome::kLate:
            return "late";
        case PacketOutcome::kDuplicate:
            return "duplicate";
    }
    return "unknown";
}

std::uint32_t scan_fields(UdpProfileLidar profile) {
    const ProfileLayout& layout = profile_layout(profile);
    // packet_format's Field and ScanField list the same channels in the same order.
    static_assert(
        static_cast<int>(Field::kNearIr) == static_cast<int>(ScanField::kNearIr) &&
            static_cast<int>(Field::kRange2) == static_cast<int>(ScanField::kRange2) &&
            static_cast<int>(Field::kReflectivity2) == static_cast<int>(ScanField::kReflectivity2),
        "Field and ScanField must stay in the same order");
    std::uint32_t bits = 0;
    for (int f = 0; f < kFieldCount; ++f) {
        if (layout.fields[f].present()) bits |= 1u << f;
    }
    return bits;
}

LidarScanLayout scan_layout(const SensorInfo& info) {
    LidarScanLayout layout;
    if (info.pixels_per_column <= 0 || info.columns_per_frame <= 0) {
        throw std::invalid_argument("scan layout of sensor " + info.prod_sn +
                                    ": pixels_per_column and columns_per_frame must be "
                                    "positive");
    }
    layout.rows = static_cast<std::size_t>(info.pixels_per_column);
    layout.columns = static_cast<std::size_t>(info.columns_per_frame);
    layout.fields = scan_fields(info.udp_profile_lidar);
    const int w = info.columns_per_frame;
    const auto& cw = info.column_window;
    if (cw[0] < 0 || cw[1] < 0 || cw[0] >= w || cw[1] >= w) {
        throw std::invalid_argument("scan layout of sensor " + info.prod_sn + ": column_window [" +
                                    std::to_string(cw[0]) + ", " + std::to_string(cw[1]) +
                                    "] outside 0.." + std::to_string(w - 1));
    }
    layout.column_window =
        ColumnWindow{static_cast<std::uint32_t>(cw[0]), static_cast<std::uint32_t>(cw[1])};
    return layout;
}

ScanAssembler::ScanAssembler(const SensorInfo& info, const ScanAssemblerParams& params, EmitFn emit)
    : format_(info),
      layout_(scan_layout(info)),
      params_(params),
      mode_(mode_expectation(info, format_), format_.header_type() == HeaderType::kFusa ? 32 : 16,
            params.mode_check),
      emit_(std::move(emit)),
      window_(
          layout_, window_params(params, format_),
          [this](const LidarScan& scan) {
              mode_.observe_frame(scan);
              counters_.mode_mismatch_frames = mode_.frames_disagreeing();
              counters_.mode_mismatches = mode_.mismatches();
              if (emit_) emit_(scan);
          },
          &counters_) {}

PacketOutcome ScanAssembler::add_packet(const std::uint8_t* data, std::size_t size) {
    ++counters_.packets;
    switch (format_.classify(data, size)) {
        case PacketKind::kLidar:
            break;
        case PacketKind::kImu:
            ++counters_.imu_packets;
            return PacketOutcome::kImu;
        case PacketKind::kWrongSize:
            ++counters_.bad_size;
            mode_.observe_wrong_size(size);
            counters_.mode_mismatches = mode_.mismatches();
            return PacketOutcome::kWrongSize;
        case PacketKind::kWrongProfile:
            ++counters_.bad_profile;
            return PacketOutcome::kWrongProfile;
    }
    if (!crc_ok(data)) return PacketOutcome::kCrcError;
    ++counters_.lidar_packets;
    mode_.observe_lidar_packet();
    LidarScan* scan = frame_of(data);
    if (!scan) return PacketOutcome::kLate;
    const std::size_t written = write_columns(data, scan);
    window_.packet_done(*scan, written);
    return written > 0 ? PacketOutcome::kAssembled : PacketOutcome::kDuplicate;
}

// FW 2.2-2.4 fill the CRC field with a fixed marker, not a CRC: skip computing it.
bool ScanAssembler::crc_ok(const std::uint8_t* data) {
    if (!params_.check_crc || !format_.has_crc() || format_.stored_crc(data) == kUnfilledCrcMarker)
        return true;
    switch (format_.check_crc(data)) {
        case CrcStatus::kValid:
            ++counters_.crc_valid;
            break;
        case CrcStatus::kInvalid:
            ++counters_.crc_errors;
            return false;
        case CrcStatus::kAbsent:
        case CrcStatus::kNotApplicable:
            break;
    }
    return true;
}

LidarScan* ScanAssembler::frame_of(const std::uint8_t* data) {
    const std::uint64_t resets = counters_.resets;
    LidarScan* scan =
        window_.scan_for(format_.frame_id(data), format_.init_id(data), format_.prod_sn(data));
    if (counters_.resets != resets) mode_.forget_previous_frame();
    return scan;
}

std::size_t ScanAssembler::write_columns(const std::uint8_t* data, LidarScan* scan) {
    const int count = format_.columns_per_packet();
    claimed_.assign(static_cast<std::size_t>(std::max(count, 0)), -1);
    bool consecutive = true;  // every column taken, measurement ids in a row
    std::size_t written = 0;
    for (int i = 0; i < count; ++i) {
        const std::uint8_t* col = format_.column(data, i);
        const std::uint16_t m = format_.column_measurement_id(col);
        if (!window_.claim_column(*scan, m)) {
            consecutive = false;
            continue;
        }
        ++written;
        claimed_[static_cast<std::size_t>(i)] = m;
        consecutive = consecutive && m == claimed_[0] + i;
        scan->timestamp_ns[m] = format_.column_timestamp_ns(col);
        scan->measurement_id[m] = m;
        scan->status[m] = format_.column_status(col);
    }
    // A whole packet (the usual case) row by row; otherwise the columns taken one by one.
    if (consecutive && count > 0) {
        write_pixels(data, 0, count, static_cast<std::uint16_t>(claimed_[0]), scan);
        return written;
    }
    for (int i = 0; i < count; ++i) {
        const int m = claimed_[static_cast<std::size_t>(i)];
        if (m >= 0) write_pixels(data, i, 1, static_cast<std::uint16_t>(m), scan);
    }
    return written;
}

void ScanAssembler::write_pixels(const std::uint8_t* data, int first, int count, std::uint16_t m,
                                 LidarScan* scan) const {
    const std::ptrdiff_t stride = static_cast<std::ptrdiff_t>(layout_.columns);
    // Fields the scan lacks are empty vectors: the profile lacks them too.
    const auto read = [&](Field f, auto& image) {
        if (!image.empty()) format_.read_columns(data, first, count, f, &image[m], stride);
    };
    read(Field::kRange, scan->range_mm);
    read(Field::kRange2, scan->range2_mm);
    read(Field::kSignal, scan->signal);
    read(Field::kSignal2, scan->signal2);
    read(Field::kReflectivity, scan->reflectivity);
    read(Field::kReflectivity2, scan->reflectivity2);
    read(Field::kNearIr, scan->near_ir);
}

void ScanAssembler::flush() { window_.flush(); }

}  // namespace lidarfuse::ouster
