#pragma once
// The header of a PLY file (Greg Turk's format, 1.0):
//   ply
//   format ascii | binary_little_endian | binary_big_endian 1.0
//   comment ... / obj_info ...                 (any number, anywhere in the header)
//   element <name> <count>
//   property <type> <name>                     (scalar)
//   property list <count type> <item type> <name>
//   end_header
// Types: char uchar short ushort int uint float double and their sized spellings int8
// uint8 int16 uint16 int32 uint32 float32 float64. The element `vertex` must have scalar
// x, y, z and may have a scalar intensity; every other element and property is read past.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/io/cloud_scalar.hpp"

namespace lidarfuse::io {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct PlyProperty {
    std::string name;
    ScalarType type;  // the value's type, or a list's item type
    bool is_list = false;
    ScalarType count_type;  // lists only: an integer type
};

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;

    // Index of the property called `name`, or -1.
    int find(const std::string& property_name) const;
    // Bytes of one entry in binary data without its lists' items (their counts included).
    std::uint64_t min_entry_bytes() const;
};

struct PlyHeader {
    PlyFormat format = PlyFormat::kAscii;
    std::vector<PlyElement> elements;  // in file order
    std::size_t vertex_element = 0;    // index of `vertex` in elements
    std::size_t data_offset = 0;       // first byte after end_header's line
    std::size_t data_line = 0;         // the end_header line's number
};

// Parses and checks the header; errors name `name` and the line.
PlyHeader parse_ply_header(const std::string& bytes, const std::string& name);

}  // namespace lidarfuse::io
