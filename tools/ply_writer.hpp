#pragma once
// Writes points as a PLY file: binary little endian, one vertex per point with float
// x, y, z (metres, in whatever frame the caller's points are), the vertex count in the
// header. Readable by CloudCompare, MeshLab, Open3D, PCL.

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace lidarfuse::tools {

// Throws std::runtime_error naming the file when it cannot be written. `comment` (one
// line, optional) goes into the header.
void write_ply(const std::filesystem::path& file, const std::vector<Eigen::Vector3d>& points,
               const std::string& comment = "");

}  // namespace lidarfuse::tools
