#pragma once
// A fused cloud as a file, every point 18 bytes little endian: float x, y, z (metres, the
// fused frame), float intensity, uint8 sensor (index in the station config), uint8 dynamic
// (1 = flagged by the background model). PLY (binary_little_endian, properties x y z
// intensity sensor dynamic) or PCD (v0.7, DATA binary, FIELDS x y z intensity sensor_id
// dynamic, as PCL and CloudCompare read it). Written atomically (temporary file + rename).

#include <filesystem>

#include "core/pipeline/fusion_types.hpp"

namespace lidarfuse::io {

// Throw std::runtime_error naming the file when it cannot be written.
void write_fused_cloud_ply(const std::filesystem::path& file, const core::FusedCloud& cloud);
void write_fused_cloud_pcd(const std::filesystem::path& file, const core::FusedCloud& cloud);

// Reads back what write_fused_cloud_ply wrote. Only that layout is accepted; anything else
// throws std::runtime_error naming the file and the header line that differs.
core::FusedCloud read_fused_cloud_ply(const std::filesystem::path& file);

}  // namespace lidarfuse::io
