#pragma once
// Reads back a fused cloud that `lidarfuse fuse --save-cloud` / lidarfused wrote
// (drivers/io/fused_cloud_file.hpp: binary little-endian PLY, float x y z intensity, uchar sensor
// dynamic). Only that layout is accepted; anything else throws naming the file and the
// header line that differs.

#include <filesystem>

#include "core/pipeline/fusion_types.hpp"

namespace lidarfuse::tools {

core::FusedCloud read_fused_cloud_ply(const std::filesystem::path& file);

}  // namespace lidarfuse::tools
