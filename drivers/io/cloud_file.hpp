#pragma once
// Point-cloud files: PCD (v0.5-0.7; DATA ascii, binary, binary_compressed) and PLY (ascii,
// binary little / big endian), read into points plus an optional intensity, and written
// back (float32 x y z [intensity]) for round trips and for tools that hand clouds to
// others. Readers keep only finite points that are not exactly (0, 0, 0) (Ouster's
// organised clouds mark a pixel without a return so) and count the rest in num_dropped.
//
// Errors: std::runtime_error whose message starts with the file name (or `name` for the
// in-memory readers), says what is wrong and what was expected; a bad file never yields a
// short cloud. Writers write atomically (temporary file + rename).
//
// Implementation: cloud_pcd_header / cloud_pcd_reader / cloud_pcd_writer,
// cloud_ply_header / cloud_ply_reader / cloud_ply_writer, cloud_lzf (binary_compressed),
// cloud_scalar and cloud_text (shared decoding), cloud_file_support (builder, file I/O).

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/point_cloud.hpp"

namespace lidarfuse::io {

struct CloudFile {
    core::PointCloud cloud;        // points only (metres, the file's frame, VIEWPOINT applied)
    std::vector<float> intensity;  // same size as cloud.points when the file has an intensity
                                   // field, else empty
    std::size_t num_dropped = 0;   // NaN / non-finite / all-zero points dropped
};

// By extension: .pcd or .ply (case-insensitive); anything else: an error naming the file.
CloudFile read_cloud_file(const std::filesystem::path& file);

CloudFile read_pcd(const std::filesystem::path& file);
// Parses from memory (fuzzing, tests); `name` is used in error messages.
CloudFile read_pcd(const std::string& bytes, const std::string& name);

CloudFile read_ply(const std::filesystem::path& file);
CloudFile read_ply(const std::string& bytes, const std::string& name);

enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };
// Fields x y z [intensity], float32, unorganised (WIDTH = POINTS, HEIGHT 1), identity
// VIEWPOINT. Intensity is written when cloud.intensity is not empty (it must then match the
// points). Points are written as they are (a NaN stays NaN).
void write_pcd(const std::filesystem::path& file, const CloudFile& cloud, PcdEncoding encoding);

enum class PlyEncoding { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
// Element vertex with float x y z [intensity]; otherwise as write_pcd.
void write_ply(const std::filesystem::path& file, const CloudFile& cloud, PlyEncoding encoding);

}  // namespace lidarfuse::io
