#pragma once
// A fused cloud as a binary little-endian PLY: per vertex float x, y, z (metres, root
// frame), float intensity, uchar sensor (index in the station config), uchar dynamic
// (1 = flagged by the background model). Written atomically (temporary file + rename).

#include <filesystem>

#include "core/pipeline/fusion_types.hpp"

namespace lidarfuse::io {

// Throws std::runtime_error naming the file when it cannot be written.
void write_fused_cloud_ply(const std::filesystem::path& file, const core::FusedCloud& cloud);

}  // namespace lidarfuse::io
