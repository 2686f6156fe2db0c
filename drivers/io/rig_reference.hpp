#pragma once
// A rig's reference transform as the shared real data stores it (../shared/data/real,
// `T_a_b.txt`): 16 numbers, a 4 x 4 row-major matrix, metres, p_a = T * p_b.

#include <Eigen/Geometry>
#include <filesystem>

namespace lidarfuse::io {

// Throws std::runtime_error naming the file when it cannot be read or holds fewer than 16
// numbers, or when its last row is not 0 0 0 1.
Eigen::Isometry3d read_rig_reference(const std::filesystem::path& file);

}  // namespace lidarfuse::io
