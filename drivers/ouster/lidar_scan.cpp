#include "drivers/ouster/lidar_scan.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace lidarfuse::ouster {

namespace {

template <typename T>
void zero(std::vector<T>& v) {
    std::fill(v.begin(), v.end(), T{0});
}

template <typename T>
void allocate_if(bool wanted, std::size_t n, std::vector<T>& v) {
    if (wanted) v.assign(n, T{0});
}

}  // namespace

const char* field_name(ScanField f) {
    switch (f) {
        case ScanField::kRange:
            return "RANGE";
        case ScanField::kRange2:
            return "RANGE2";
        case ScanField::kSignal:
            return "SIGNAL";
        case ScanField::kSignal2:
            return "SIGNAL2";
        case ScanField::kReflectivity:
            return "REFLECTIVITY";
        case ScanField::kReflectivity2:
            return "REFLECTIVITY2";
        case ScanField::kNearIr:
            return "NEAR_IR";
    }
    return "UNKNOWN";
}

std::size_t ColumnWindow::size(std::size_t width) const {
    if (first <= last) return static_cast<std::size_t>(last - first) + 1;
    return (width - first) + static_cast<std::size_t>(last) + 1;
}

LidarScan::LidarScan(const LidarScanLayout& layout) : layout_(layout) {
    if (layout.rows == 0 || layout.columns == 0) {
        throw std::invalid_argument("LidarScan: rows and columns must be positive (got " +
                                    std::to_string(layout.rows) + " x " +
                                    std::to_string(layout.columns) + ")");
    }
    const auto w = static_cast<std::uint32_t>(layout.columns);
    window_ = layout.column_window.value_or(ColumnWindow{0, w - 1});
    if (window_.first >= w || window_.last >= w) {
        throw std::invalid_argument("LidarScan: column window [" + std::to_string(window_.first) +
                                    ", " + std::to_string(window_.last) + "] outside a frame of " +
                                    std::to_string(w) + " columns");
    }
    expected_columns_ = window_.size(layout.columns);

    const std::size_t n = layout.rows * layout.columns;
    allocate_if(has(ScanField::kRange), n, range_mm);
    allocate_if(has(ScanField::kRange2), n, range2_mm);
    allocate_if(has(ScanField::kSignal), n, signal);
    allocate_if(has(ScanField::kSignal2), n, signal2);
    allocate_if(has(ScanField::kReflectivity), n, reflectivity);
    allocate_if(has(ScanField::kReflectivity2), n, reflectivity2);
    allocate_if(has(ScanField::kNearIr), n, near_ir);
    timestamp_ns.assign(layout.columns, 0);
    measurement_id.assign(layout.columns, 0);
    status.assign(layout.columns, 0);
    received.assign(layout.columns, 0);
}

void LidarScan::reset() {
    zero(range_mm);
    zero(range2_mm);
    zero(signal);
    zero(signal2);
    zero(reflectivity);
    zero(reflectivity2);
    zero(near_ir);
    zero(timestamp_ns);
    zero(measurement_id);
    zero(status);
    zero(received);
    frame_id = 0;
    init_id = 0;
    serial = 0;
    packets = 0;
    duplicate_columns = 0;
    bad_columns = 0;
    received_expected_ = 0;
}

const void* LidarScan::field_data(ScanField f) const {
    switch (f) {
        case ScanField::kRange:
            return range_mm.data();
        case ScanField::kRange2:
            return range2_mm.data();
        case ScanField::kSignal:
            return signal.data();
        case ScanField::kSignal2:
            return signal2.data();
        case ScanField::kReflectivity:
            return reflectivity.data();
        case ScanField::kReflectivity2:
            return reflectivity2.data();
        case ScanField::kNearIr:
            return near_ir.data();
    }
    return nullptr;
}

std::size_t LidarScan::field_bytes(ScanField f) const {
    switch (f) {
        case ScanField::kRange:
            return range_mm.size() * sizeof(std::uint32_t);
        case ScanField::kRange2:
            return range2_mm.size() * sizeof(std::uint32_t);
        case ScanField::kSignal:
            return signal.size() * sizeof(std::uint16_t);
        case ScanField::kSignal2:
            return signal2.size() * sizeof(std::uint16_t);
        case ScanField::kReflectivity:
            return reflectivity.size();
        case ScanField::kReflectivity2:
            return reflectivity2.size();
        case ScanField::kNearIr:
            return near_ir.size() * sizeof(std::uint16_t);
    }
    return 0;
}

double LidarScan::completeness() const {
    if (expected_columns_ == 0) return 0.0;
    return static_cast<double>(received_expected_) / static_cast<double>(expected_columns_);
}

bool LidarScan::mark_received(std::size_t col) {
    if (col >= layout_.columns || received[col]) return false;
    received[col] = 1;
    if (window_.contains(static_cast<std::uint32_t>(col))) ++received_expected_;
    return true;
}

std::vector<ScanArrayView> digest_arrays(const LidarScan& scan) {
    std::vector<ScanArrayView> out;
    for (ScanField f : kAllScanFields) {
        if (scan.has(f)) out.push_back({field_name(f), scan.field_data(f), scan.field_bytes(f)});
    }
    out.push_back(
        {"TIMESTAMP", scan.timestamp_ns.data(), scan.timestamp_ns.size() * sizeof(std::uint64_t)});
    out.push_back({"MEASUREMENT_ID", scan.measurement_id.data(),
                   scan.measurement_id.size() * sizeof(std::uint16_t)});
    out.push_back({"STATUS", scan.status.data(), scan.status.size() * sizeof(std::uint64_t)});
    return out;
}

}  // namespace lidarfuse::ouster
