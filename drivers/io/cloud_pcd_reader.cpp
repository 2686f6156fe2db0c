// read_pcd(bytes, name): the points of a PCD file, after cloud_pcd_header.hpp's checks.
// DATA binary holds the points one after another (array of structs), binary_compressed the
// same values field by field (struct of arrays) behind LZF, ascii one row per point.
// Multi-byte values are little endian (PCL writes the x86 host's order).
#include <algorithm>

#include "drivers/io/cloud_file.hpp"
#include "drivers/io/cloud_file_support.hpp"
#include "drivers/io/cloud_lzf.hpp"
#include "drivers/io/cloud_pcd_header.hpp"
#include "drivers/io/cloud_text.hpp"

namespace lidarfuse::io {

namespace {

// Where one field's values lie in decoded binary data: the first point's value and the
// step from one point to the next.
struct Column {
    const unsigned char* first = nullptr;
    std::size_t stride = 0;
    ScalarType type;

    double at(std::size_t i) const { return decode_scalar(first + i * stride, type, false); }
};

struct Columns {
    Column x, y, z, intensity;
    bool has_intensity = false;
};

// Array of structs (binary): field f of point i at i * point_size + f.offset.
// Struct of arrays (binary_compressed): at points * f.offset + i * f.size (COUNT 1).
Columns locate_columns(const PcdHeader& header, const unsigned char* data, bool struct_of_arrays) {
    const auto column = [&](const PcdField& field) {
        if (struct_of_arrays) {
            return Column{data + header.points * field.offset, field.type.size, field.type};
        }
        return Column{data + field.offset, header.point_size, field.type};
    };
    Columns columns;
    columns.x = column(*header.find("x"));
    columns.y = column(*header.find("y"));
    columns.z = column(*header.find("z"));
    if (const PcdField* intensity = header.find("intensity")) {
        columns.intensity = column(*intensity);
        columns.has_intensity = true;
    }
    return columns;
}

CloudFile decode_points(const PcdHeader& header, const Columns& c) {
    CloudBuilder builder(c.has_intensity, header.T_viewpoint);
    builder.reserve(header.points);  // the callers checked the data holds them all
    for (std::size_t i = 0; i < header.points; ++i) {
        const float intensity = c.has_intensity ? static_cast<float>(c.intensity.at(i)) : 0.0f;
        builder.add(c.x.at(i), c.y.at(i), c.z.at(i), intensity);
    }
    return builder.finish();
}

std::uint64_t data_bytes(const PcdHeader& header, const std::string& name) {
    return checked_product(header.points, header.point_size, name, "POINTS x point size");
}

// PCL before 1.8 stretched a binary file to getpagesize() + its data bytes (lseek and a
// one-byte write before mmap), so its files end in up to a page of zero bytes after the
// data. Such padding is accepted; any other byte after the data is an error.
constexpr std::uint64_t kMaxZeroPadding = 1 << 16;  // the largest page size in use

bool is_zero_padding(const std::string& bytes, std::uint64_t from) {
    if (from > bytes.size() || bytes.size() - from > kMaxZeroPadding) return false;
    return std::all_of(bytes.begin() + static_cast<std::ptrdiff_t>(from), bytes.end(),
                       [](char c) { return c == 0; });
}

std::string size_text(const PcdHeader& header, std::uint64_t needed) {
    return "POINTS x point size = " + std::to_string(header.points) + " x " +
           std::to_string(header.point_size) + " = " + std::to_string(needed);
}

CloudFile read_binary(const PcdHeader& header, const std::string& bytes, const std::string& name) {
    const std::uint64_t available = bytes.size() - header.data_offset;
    const std::uint64_t needed = data_bytes(header, name);
    if (available < needed) {
        cloud_error(name, "truncated: DATA binary needs " + size_text(header, needed) +
                              " bytes after the header, the file has " + std::to_string(available));
    }
    if (available > needed && !is_zero_padding(bytes, header.data_offset + needed)) {
        cloud_error(name, std::to_string(available - needed) + " bytes after the last point " +
                              "(DATA binary expects exactly " + size_text(header, needed) +
                              " bytes)");
    }
    const auto* data = reinterpret_cast<const unsigned char*>(bytes.data()) + header.data_offset;
    return decode_points(header, locate_columns(header, data, false));
}

// The sizes in front of the LZF data against the bytes after them and against the header,
// before anything is allocated.
void check_lzf_sizes(std::uint64_t compressed, std::uint64_t uncompressed, std::uint64_t available,
                     bool padded, const PcdHeader& header, const std::string& name) {
    const std::uint64_t needed = data_bytes(header, name);
    if (compressed > available || (compressed < available && !padded)) {
        cloud_error(name, "compressed size " + std::to_string(compressed) + " does not match the " +
                              std::to_string(available) +
                              " bytes after the two sizes (truncated file, or trailing data that "
                              "is not zero padding)");
    }
    if (uncompressed != needed) {
        cloud_error(name, "uncompressed size " + std::to_string(uncompressed) + " does not match " +
                              size_text(header, needed));
    }
    if (needed > compressed * kLzfMaxExpansion) {
        cloud_error(name, "uncompressed size " + std::to_string(needed) + " cannot come from " +
                              std::to_string(compressed) + " LZF bytes (LZF expands at most " +
                              std::to_string(kLzfMaxExpansion) + "-fold)");
    }
}

CloudFile read_compressed(const PcdHeader& header, const std::string& bytes,
                          const std::string& name) {
    const std::uint64_t available = bytes.size() - header.data_offset;
    if (available < 8) {
        cloud_error(name,
                    "truncated: DATA binary_compressed needs two uint32 sizes (compressed, "
                    "uncompressed) after the header, the file has " +
                        std::to_string(available) + " bytes");
    }
    const auto* sizes = reinterpret_cast<const unsigned char*>(bytes.data()) + header.data_offset;
    constexpr ScalarType kUint32{ScalarKind::kUnsigned, 4};
    const auto compressed = static_cast<std::uint64_t>(decode_scalar(sizes, kUint32, false));
    const auto uncompressed = static_cast<std::uint64_t>(decode_scalar(sizes + 4, kUint32, false));
    const bool padded =
        compressed < available - 8 && is_zero_padding(bytes, header.data_offset + 8 + compressed);
    check_lzf_sizes(compressed, uncompressed, available - 8, padded, header, name);
    const std::string columns =
        lzf_decompress_exact(bytes.data() + header.data_offset + 8, compressed, uncompressed, name);
    const auto* data = reinterpret_cast<const unsigned char*>(columns.data());
    return decode_points(header, locate_columns(header, data, true));
}

// Index of each needed field's value in an ascii row, and every value's type.
struct RowLayout {
    std::vector<ScalarType> types;
    std::vector<const PcdField*> fields;
    std::size_t x = 0, y = 0, z = 0, intensity = 0;
    bool has_intensity = false;
};

RowLayout row_layout(const PcdHeader& header) {
    RowLayout layout;
    for (const auto& field : header.fields) {
        layout.types.insert(layout.types.end(), field.count, field.type);
        layout.fields.insert(layout.fields.end(), field.count, &field);
    }
    layout.x = header.find("x")->value_index;
    layout.y = header.find("y")->value_index;
    layout.z = header.find("z")->value_index;
    if (const PcdField* intensity = header.find("intensity")) {
        layout.intensity = intensity->value_index;
        layout.has_intensity = true;
    }
    return layout;
}

// Parses one row's tokens into `values`, or an error naming the line.
void parse_row(const std::vector<std::string_view>& tokens, const RowLayout& layout,
               const std::string& name, std::size_t line, std::vector<double>* values) {
    if (tokens.size() != layout.types.size()) {
        cloud_line_error(name, line,
                         "expected " + std::to_string(layout.types.size()) +
                             " values per row (FIELDS with their COUNTs), got " +
                             std::to_string(tokens.size()));
    }
    for (std::size_t j = 0; j < tokens.size(); ++j) {
        if (!parse_scalar_text(tokens[j], layout.types[j], &(*values)[j])) {
            cloud_line_error(name, line,
                             "value " + std::to_string(j + 1) + " (field " +
                                 layout.fields[j]->name + ") \"" +
                                 std::string(tokens[j].substr(0, 40)) + "\" is not a number");
        }
    }
}

CloudFile read_ascii(const PcdHeader& header, const std::string& bytes, const std::string& name) {
    const std::uint64_t available = bytes.size() - header.data_offset;
    // A row of V values takes at least 2V bytes (a digit and a blank or newline each).
    if (header.points > (available + 1) / (2 * header.values_per_point)) {
        cloud_error(name, "truncated: POINTS " + std::to_string(header.points) + " rows of " +
                              std::to_string(header.values_per_point) +
                              " values cannot fit in the " + std::to_string(available) +
                              " bytes after the header");
    }
    const RowLayout layout = row_layout(header);
    CloudBuilder builder(layout.has_intensity, header.T_viewpoint);
    builder.reserve(header.points);
    TextCursor cursor(bytes, header.data_offset, header.data_line + 1);
    std::vector<std::string_view> tokens;
    std::vector<double> v(layout.types.size());
    for (std::uint64_t row = 0; row < header.points; ++row) {
        if (!cursor.next_tokens(&tokens)) {
            cloud_error(name, "truncated: " + std::to_string(row) + " ascii rows, POINTS says " +
                                  std::to_string(header.points));
        }
        parse_row(tokens, layout, name, cursor.line_number(), &v);
        const float intensity =
            layout.has_intensity ? static_cast<float>(v[layout.intensity]) : 0.0f;
        builder.add(v[layout.x], v[layout.y], v[layout.z], intensity);
    }
    if (cursor.next_tokens(&tokens)) {
        cloud_line_error(name, cursor.line_number(),
                         "more ascii rows than POINTS " + std::to_string(header.points));
    }
    return builder.finish();
}

}  // namespace

CloudFile read_pcd(const std::string& bytes, const std::string& name) {
    const PcdHeader header = parse_pcd_header(bytes, name);
    switch (header.data) {
        case PcdData::kAscii:
            return read_ascii(header, bytes, name);
        case PcdData::kBinary:
            return read_binary(header, bytes, name);
        case PcdData::kBinaryCompressed:
            return read_compressed(header, bytes, name);
    }
    cloud_error(name, "unknown DATA kind");
}

}  // namespace lidarfuse::io
