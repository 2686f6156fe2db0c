#include "drivers/io/cloud_ply_header.hpp"

#include <map>
#include <set>

#include "drivers/io/cloud_file_support.hpp"
#include "drivers/io/cloud_text.hpp"

namespace lidarfuse::io {

namespace {

const std::map<std::string_view, ScalarType> kTypes = {
    {"char", {ScalarKind::kSigned, 1}},     {"int8", {ScalarKind::kSigned, 1}},
    {"uchar", {ScalarKind::kUnsigned, 1}},  {"uint8", {ScalarKind::kUnsigned, 1}},
    {"short", {ScalarKind::kSigned, 2}},    {"int16", {ScalarKind::kSigned, 2}},
    {"ushort", {ScalarKind::kUnsigned, 2}}, {"uint16", {ScalarKind::kUnsigned, 2}},
    {"int", {ScalarKind::kSigned, 4}},      {"int32", {ScalarKind::kSigned, 4}},
    {"uint", {ScalarKind::kUnsigned, 4}},   {"uint32", {ScalarKind::kUnsigned, 4}},
    {"float", {ScalarKind::kFloat, 4}},     {"float32", {ScalarKind::kFloat, 4}},
    {"double", {ScalarKind::kFloat, 8}},    {"float64", {ScalarKind::kFloat, 8}},
};

class PlyHeaderParser {
public:
    PlyHeaderParser(const std::string& bytes, const std::string& name)
        : name_(name), cursor_(bytes, 0, 1) {}

    PlyHeader parse();

private:
    [[noreturn]] void fail(const std::string& what) {
        cloud_line_error(name_, cursor_.line_number(), what);
    }
    ScalarType type(std::string_view token);
    void parse_magic();
    void parse_format(PlyHeader* header);
    void parse_element(PlyHeader* header);
    void parse_property(PlyHeader* header);
    void check(PlyHeader* header);

    const std::string& name_;
    TextCursor cursor_;
    std::vector<std::string_view> tokens_;
    bool have_format_ = false;
};

ScalarType PlyHeaderParser::type(std::string_view token) {
    const auto it = kTypes.find(token);
    if (it == kTypes.end()) {
        fail("unknown PLY type \"" + std::string(token.substr(0, 40)) +
             "\" (expected char, uchar, short, ushort, int, uint, float, double or a sized "
             "name such as float32)");
    }
    return it->second;
}

void PlyHeaderParser::parse_magic() {
    std::string_view line;
    if (cursor_.next_line(&line)) split_tokens(line, &tokens_);
    if (tokens_.size() != 1 || tokens_[0] != "ply") {
        cloud_error(name_, "not a PLY file (expected \"ply\" on the first line)");
    }
}

void PlyHeaderParser::parse_format(PlyHeader* header) {
    if (have_format_) fail("format appears twice");
    if (tokens_.size() != 3 || (tokens_[2] != "1.0" && tokens_[2] != "1")) {
        fail("expected \"format ascii|binary_little_endian|binary_big_endian 1.0\"");
    }
    if (tokens_[1] == "ascii") {
        header->format = PlyFormat::kAscii;
    } else if (tokens_[1] == "binary_little_endian") {
        header->format = PlyFormat::kBinaryLittleEndian;
    } else if (tokens_[1] == "binary_big_endian") {
        header->format = PlyFormat::kBinaryBigEndian;
    } else {
        fail("unknown format \"" + std::string(tokens_[1].substr(0, 40)) +
             "\" (expected ascii, binary_little_endian or binary_big_endian)");
    }
    have_format_ = true;
}

void PlyHeaderParser::parse_element(PlyHeader* header) {
    PlyElement element;
    if (tokens_.size() != 3 || !parse_count(tokens_[2], &element.count)) {
        fail("expected \"element <name> <count>\" with a non-negative integer count");
    }
    element.name = std::string(tokens_[1]);
    for (const auto& other : header->elements) {
        if (other.name == element.name) fail("element " + element.name + " appears twice");
    }
    header->elements.push_back(std::move(element));
}

void PlyHeaderParser::parse_property(PlyHeader* header) {
    if (header->elements.empty()) fail("property before any element");
    PlyElement& element = header->elements.back();
    PlyProperty property;
    if (tokens_.size() == 5 && tokens_[1] == "list") {
        property.is_list = true;
        property.count_type = type(tokens_[2]);
        property.type = type(tokens_[3]);
        if (property.count_type.kind == ScalarKind::kFloat) {
            fail("list " + std::string(tokens_[4]) + ": the count type must be an integer type");
        }
        property.name = std::string(tokens_[4]);
    } else if (tokens_.size() == 3 && tokens_[1] != "list") {
        property.type = type(tokens_[1]);
        property.name = std::string(tokens_[2]);
    } else {
        fail(
            "expected \"property <type> <name>\" or \"property list <count type> <item type> "
            "<name>\"");
    }
    if (element.find(property.name) >= 0) {
        fail("element " + element.name + ": property " + property.name + " appears twice");
    }
    element.properties.push_back(std::move(property));
}

void PlyHeaderParser::check(PlyHeader* header) {
    if (!have_format_) cloud_error(name_, "no format line in the PLY header");
    bool have_vertex = false;
    for (std::size_t i = 0; i < header->elements.size(); ++i) {
        const PlyElement& element = header->elements[i];
        if (element.properties.empty() && element.count > 0) {
            cloud_error(name_, "element " + element.name + " has " + std::to_string(element.count) +
                                   " entries but no properties");
        }
        if (element.name != "vertex") continue;
        have_vertex = true;
        header->vertex_element = i;
        for (const char* wanted : {"x", "y", "z", "intensity"}) {
            const int at = element.find(wanted);
            const bool optional = std::string(wanted) == "intensity";
            if ((at < 0 && !optional) || (at >= 0 && element.properties[at].is_list)) {
                cloud_error(name_, std::string("element vertex needs a scalar property ") + wanted +
                                       (optional ? " (or none)" : ""));
            }
        }
    }
    if (!have_vertex) cloud_error(name_, "no element vertex in the PLY header");
}

PlyHeader PlyHeaderParser::parse() {
    PlyHeader header;
    parse_magic();
    while (cursor_.next_tokens(&tokens_)) {
        const std::string_view keyword = tokens_[0];
        if (keyword == "comment" || keyword == "obj_info") continue;
        if (keyword == "end_header") {
            check(&header);
            header.data_offset = cursor_.offset();
            header.data_line = cursor_.line_number();
            return header;
        }
        if (keyword == "format") {
            parse_format(&header);
        } else if (keyword == "element") {
            parse_element(&header);
        } else if (keyword == "property") {
            parse_property(&header);
        } else {
            fail("unknown PLY header keyword \"" + std::string(keyword.substr(0, 40)) +
                 "\" (expected format, element, property, comment, obj_info or end_header)");
        }
    }
    cloud_error(name_, "no end_header line: the PLY header is truncated");
}

}  // namespace

int PlyElement::find(const std::string& property_name) const {
    for (std::size_t i = 0; i < properties.size(); ++i) {
        if (properties[i].name == property_name) return static_cast<int>(i);
    }
    return -1;
}

std::uint64_t PlyElement::min_entry_bytes() const {
    std::uint64_t bytes = 0;
    for (const auto& property : properties) {
        bytes += property.is_list ? property.count_type.size : property.type.size;
    }
    return bytes;
}

PlyHeader parse_ply_header(const std::string& bytes, const std::string& name) {
    return PlyHeaderParser(bytes, name).parse();
}

}  // namespace lidarfuse::io
