#pragma once
// The header of a PCD file (PCL's format, v0.5-0.7): one keyword per line, in any order,
// `#` comments, ending with the DATA line after which the points start.
//   VERSION 0.7              optional (0.5, 0.6, 0.7, also written .7)
//   FIELDS x y z intensity   required (v0.5 files may say COLUMNS); `_` = padding
//   SIZE 4 4 4 4             required, bytes per value: 1, 2, 4, 8
//   TYPE F F F F             required, I / U / F (F only with SIZE 4 or 8)
//   COUNT 1 1 1 1            optional (default 1), values per field
//   WIDTH 1024               required
//   HEIGHT 128               optional (default 1); WIDTH x HEIGHT = POINTS
//   VIEWPOINT tx ty tz qw qx qy qz   optional (default identity): pose of the file's
//                            points, applied on reading (p' = q p + t)
//   POINTS 131072            optional (default WIDTH x HEIGHT)
//   DATA ascii | binary | binary_compressed
// Fields x, y, z must be F4 or F8 with COUNT 1; intensity (optional) any type, COUNT 1.

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/io/cloud_scalar.hpp"

namespace lidarfuse::io {

enum class PcdData { kAscii, kBinary, kBinaryCompressed };

struct PcdField {
    std::string name;
    ScalarType type;
    std::uint64_t count = 1;
    std::uint64_t offset = 0;       // byte offset in one point's record (binary)
    std::uint64_t value_index = 0;  // index of its first value in an ascii row
};

// Upper bound of one point's bytes: keeps every size product far from overflow and refuses
// headers no real file has (PCL's largest descriptors are a few kB per point).
constexpr std::uint64_t kPcdMaxPointBytes = 1 << 20;

struct PcdHeader {
    std::vector<PcdField> fields;
    std::uint64_t point_size = 0;        // bytes per point (binary), <= kPcdMaxPointBytes
    std::uint64_t values_per_point = 0;  // ascii values per row
    std::uint64_t width = 0;
    std::uint64_t height = 1;
    std::uint64_t points = 0;
    Eigen::Isometry3d T_viewpoint = Eigen::Isometry3d::Identity();
    PcdData data = PcdData::kAscii;
    std::size_t data_offset = 0;  // first byte after the DATA line
    std::size_t data_line = 0;    // the DATA line's number (ascii rows follow it)

    // The field called `name`, or nullptr.
    const PcdField* find(const std::string& name) const;
};

// Parses and checks the header; the error (naming `name`, the line and every problem with
// the fields) is thrown before any point is read.
PcdHeader parse_pcd_header(const std::string& bytes, const std::string& name);

}  // namespace lidarfuse::io
