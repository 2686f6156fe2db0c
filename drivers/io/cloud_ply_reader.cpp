// read_ply(bytes, name): the vertices of a PLY file, after cloud_ply_header.hpp's checks.
// Every element is read in file order, also those before and after `vertex` (their lists
// decide where the next element starts in binary data), so a truncated file or bytes after
// the last element are reported, never skipped.
#include <algorithm>

#include "drivers/io/cloud_file.hpp"
#include "drivers/io/cloud_file_support.hpp"
#include "drivers/io/cloud_ply_header.hpp"
#include "drivers/io/cloud_text.hpp"

namespace lidarfuse::io {

namespace {

// For each property of the vertex element: 0..3 = x, y, z, intensity; -1 = not needed.
std::vector<int> vertex_slots(const PlyElement& vertex) {
    std::vector<int> slots(vertex.properties.size(), -1);
    const char* wanted[] = {"x", "y", "z", "intensity"};
    for (int slot = 0; slot < 4; ++slot) {
        const int at = vertex.find(wanted[slot]);
        if (at >= 0) slots[static_cast<std::size_t>(at)] = slot;
    }
    return slots;
}

std::string entry_text(const PlyElement& element, std::uint64_t entry) {
    return "element " + element.name + " entry " + std::to_string(entry + 1) + " of " +
           std::to_string(element.count);
}

class BinaryPlyReader {
public:
    BinaryPlyReader(const PlyHeader& header, const std::string& bytes, const std::string& name)
        : header_(header),
          data_(reinterpret_cast<const unsigned char*>(bytes.data())),
          size_(bytes.size()),
          pos_(header.data_offset),
          big_endian_(header.format == PlyFormat::kBinaryBigEndian),
          name_(name) {}

    CloudFile read();

private:
    void check_room(const PlyElement& element);
    const unsigned char* take(std::uint64_t bytes, const PlyElement& element, std::uint64_t entry);
    void read_entry(const PlyElement& element, std::uint64_t entry, const std::vector<int>* slots,
                    double* values);

    const PlyHeader& header_;
    const unsigned char* data_;
    std::size_t size_;
    std::size_t pos_;
    bool big_endian_;
    const std::string& name_;
};

// Refuses an entry count the remaining bytes cannot hold before looping over it.
void BinaryPlyReader::check_room(const PlyElement& element) {
    const std::uint64_t min_bytes = element.min_entry_bytes();
    if (min_bytes > 0 && element.count > (size_ - pos_) / min_bytes) {
        cloud_error(name_, "truncated: element " + element.name + " announces " +
                               std::to_string(element.count) + " entries of at least " +
                               std::to_string(min_bytes) + " bytes, " +
                               std::to_string(size_ - pos_) + " bytes are left");
    }
}

const unsigned char* BinaryPlyReader::take(std::uint64_t bytes, const PlyElement& element,
                                           std::uint64_t entry) {
    if (bytes > size_ - pos_) {
        cloud_error(name_,
                    "truncated: " + entry_text(element, entry) + " runs past the end of the file");
    }
    const unsigned char* at = data_ + pos_;
    pos_ += bytes;
    return at;
}

void BinaryPlyReader::read_entry(const PlyElement& element, std::uint64_t entry,
                                 const std::vector<int>* slots, double* values) {
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (!property.is_list) {
            const unsigned char* at = take(property.type.size, element, entry);
            if (slots && (*slots)[p] >= 0) {
                values[(*slots)[p]] = decode_scalar(at, property.type, big_endian_);
            }
            continue;
        }
        const double length = decode_scalar(take(property.count_type.size, element, entry),
                                            property.count_type, big_endian_);
        if (length < 0) {
            cloud_error(name_, entry_text(element, entry) + ": list " + property.name +
                                   " has a negative length");
        }
        // At most 2^32 - 1 items of at most 8 bytes: no overflow.
        take(static_cast<std::uint64_t>(length) * property.type.size, element, entry);
    }
}

CloudFile BinaryPlyReader::read() {
    const PlyElement& vertex = header_.elements[header_.vertex_element];
    const std::vector<int> slots = vertex_slots(vertex);
    CloudBuilder builder(vertex.find("intensity") >= 0, Eigen::Isometry3d::Identity());
    for (const PlyElement& element : header_.elements) {
        check_room(element);
        const bool is_vertex = &element == &vertex;
        if (is_vertex) builder.reserve(element.count);
        double values[4] = {};
        for (std::uint64_t entry = 0; entry < element.count; ++entry) {
            read_entry(element, entry, is_vertex ? &slots : nullptr, values);
            if (is_vertex) {
                builder.add(values[0], values[1], values[2], static_cast<float>(values[3]));
            }
        }
    }
    if (pos_ != size_) {
        cloud_error(name_, std::to_string(size_ - pos_) +
                               " bytes after the last element (expected the file to end there)");
    }
    return builder.finish();
}

// One ascii entry per line: its values in property order, a list as its length followed by
// its items.
void read_ascii_entry(const std::vector<std::string_view>& tokens, const PlyElement& element,
                      const std::vector<int>* slots, double* values, const std::string& name,
                      std::size_t line) {
    std::size_t t = 0;
    const auto next = [&](ScalarType type, const PlyProperty& property) {
        double value = 0;
        if (t >= tokens.size()) {
            cloud_line_error(
                name, line,
                "element " + element.name + ": too few values (" + property.name + " missing)");
        }
        if (!parse_scalar_text(tokens[t], type, &value)) {
            cloud_line_error(name, line,
                             "property " + property.name + ": \"" +
                                 std::string(tokens[t].substr(0, 40)) + "\" is not a number");
        }
        ++t;
        return value;
    };
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (!property.is_list) {
            const double value = next(property.type, property);
            if (slots && (*slots)[p] >= 0) values[(*slots)[p]] = value;
            continue;
        }
        std::uint64_t length = 0;
        if (t >= tokens.size() || !parse_count(tokens[t], &length) ||
            length > tokens.size() - t - 1) {
            cloud_line_error(name, line,
                             "list " + property.name + ": expected a length and that many values");
        }
        ++t;
        for (std::uint64_t k = 0; k < length; ++k) next(property.type, property);
    }
    if (t != tokens.size()) {
        cloud_line_error(name, line,
                         "element " + element.name + ": expected " + std::to_string(t) +
                             " values, got " + std::to_string(tokens.size()));
    }
}

CloudFile read_ascii_ply(const PlyHeader& header, const std::string& bytes,
                         const std::string& name) {
    const PlyElement& vertex = header.elements[header.vertex_element];
    const std::vector<int> slots = vertex_slots(vertex);
    CloudBuilder builder(vertex.find("intensity") >= 0, Eigen::Isometry3d::Identity());
    // An ascii entry takes at least 2 bytes (a digit and a newline).
    builder.reserve(std::min<std::uint64_t>(vertex.count, (bytes.size() - header.data_offset) / 2));
    TextCursor cursor(bytes, header.data_offset, header.data_line + 1);
    std::vector<std::string_view> tokens;
    double values[4] = {};
    for (const PlyElement& element : header.elements) {
        const bool is_vertex = &element == &vertex;
        for (std::uint64_t entry = 0; entry < element.count; ++entry) {
            if (!cursor.next_tokens(&tokens)) {
                cloud_error(name, "truncated: " + entry_text(element, entry) + " is missing");
            }
            read_ascii_entry(tokens, element, is_vertex ? &slots : nullptr, values, name,
                             cursor.line_number());
            if (is_vertex) {
                builder.add(values[0], values[1], values[2], static_cast<float>(values[3]));
            }
        }
    }
    if (cursor.next_tokens(&tokens)) {
        cloud_line_error(name, cursor.line_number(),
                         "data after the last element (expected the file to end there)");
    }
    return builder.finish();
}

}  // namespace

CloudFile read_ply(const std::string& bytes, const std::string& name) {
    const PlyHeader header = parse_ply_header(bytes, name);
    if (header.format == PlyFormat::kAscii) return read_ascii_ply(header, bytes, name);
    return BinaryPlyReader(header, bytes, name).read();
}

}  // namespace lidarfuse::io
