#pragma once
// The counters of one sensor's scan assembly, and their one table: every place that sums,
// copies or prints them iterates kAssemblyCounterFields instead of naming each member.

#include <array>
#include <cstddef>
#include <cstdint>

#include "core/common/counter_field.hpp"

namespace lidarfuse::ouster {

// Packet-level counts are filled by the ScanAssembler, frame-level ones by the FrameWindow.
struct AssemblyCounters {
    std::uint64_t packets = 0;            // everything offered to the assembler
    std::uint64_t lidar_packets = 0;      // accepted as lidar packets of this profile
    std::uint64_t imu_packets = 0;        // recognised IMU packets (skipped)
    std::uint64_t bad_size = 0;           // neither lidar nor IMU size for this sensor
    std::uint64_t bad_profile = 0;        // right size, header does not fit the metadata
    std::uint64_t crc_valid = 0;          // CRC-64 footer present and right
    std::uint64_t crc_errors = 0;         // CRC-64 footer present and wrong (dropped)
    std::uint64_t late_packets = 0;       // frame already emitted or outside the window
    std::uint64_t duplicate_packets = 0;  // every column of the packet already arrived
    std::uint64_t duplicate_columns = 0;  // columns dropped because they already arrived
    std::uint64_t bad_columns = 0;        // measurement_id >= columns_per_frame
    std::uint64_t frames_complete = 0;
    std::uint64_t frames_incomplete = 0;
    std::uint64_t resets = 0;           // init_id / serial change or restart detected
    std::uint64_t missing_columns = 0;  // expected columns absent from emitted frames
    // Filled by the ScanAssembler's ModeCheck (mode_check.hpp): frames whose columns
    // disagree with the metadata's lidar_mode, and times the sensor was flagged for it.
    std::uint64_t mode_mismatch_frames = 0;
    std::uint64_t mode_mismatches = 0;
};

// A counter's name is as `lidarfuse inspect` prints it after "inspect_<sensor>_".
using AssemblyCounterField = core::CounterField<AssemblyCounters>;

// Every member once, in the order `lidarfuse inspect` prints them.
inline constexpr std::array<AssemblyCounterField, 17> kAssemblyCounterFields{{
    {"packets", &AssemblyCounters::packets, "packets"},
    {"lidar_packets", &AssemblyCounters::lidar_packets, "packets"},
    {"imu_packets", &AssemblyCounters::imu_packets, "packets"},
    {"bad_size_packets", &AssemblyCounters::bad_size, "packets"},
    {"bad_profile_packets", &AssemblyCounters::bad_profile, "packets"},
    {"crc_valid_packets", &AssemblyCounters::crc_valid, "packets"},
    {"crc_error_packets", &AssemblyCounters::crc_errors, "packets"},
    {"late_packets", &AssemblyCounters::late_packets, "packets"},
    {"duplicate_packets", &AssemblyCounters::duplicate_packets, "packets"},
    {"duplicate_columns", &AssemblyCounters::duplicate_columns, "columns"},
    {"bad_columns", &AssemblyCounters::bad_columns, "columns"},
    {"frames_complete", &AssemblyCounters::frames_complete, "frames"},
    {"frames_incomplete", &AssemblyCounters::frames_incomplete, "frames"},
    {"missing_columns", &AssemblyCounters::missing_columns, "columns"},
    {"resets", &AssemblyCounters::resets, "resets"},
    {"mode_mismatch_frames", &AssemblyCounters::mode_mismatch_frames, "frames"},
    {"mode_mismatches", &AssemblyCounters::mode_mismatches, "mismatches"},
}};
static_assert(sizeof(AssemblyCounters) == kAssemblyCounterFields.size() * sizeof(std::uint64_t),
              "a member of AssemblyCounters is missing from kAssemblyCounterFields");

// Sums (a sensor's counters across the assemblers of its metadata versions).
inline AssemblyCounters& operator+=(AssemblyCounters& sum, const AssemblyCounters& add) {
    for (const auto& field : kAssemblyCounterFields) sum.*field.member += add.*field.member;
    return sum;
}

}  // namespace lidarfuse::ouster
