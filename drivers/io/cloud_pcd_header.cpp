#include "drivers/io/cloud_pcd_header.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "drivers/io/cloud_file_support.hpp"
#include "drivers/io/cloud_text.hpp"

namespace lidarfuse::io {

namespace {

const std::set<std::string> kKeywords = {"VERSION",   "FIELDS", "COLUMNS", "SIZE",
                                         "TYPE",      "COUNT",  "WIDTH",   "HEIGHT",
                                         "VIEWPOINT", "POINTS", "DATA"};

// A header line: its keyword's values and where it was.
struct HeaderLine {
    std::vector<std::string_view> values;
    std::size_t line = 0;
};

// Every header line by keyword, up to and including DATA.
std::map<std::string, HeaderLine> read_header_lines(const std::string& bytes,
                                                    const std::string& name, TextCursor* cursor) {
    std::map<std::string, HeaderLine> lines;
    std::vector<std::string_view> tokens;
    std::string_view line;
    while (cursor->next_line(&line)) {
        split_tokens(line, &tokens);
        if (tokens.empty() || tokens[0][0] == '#') continue;
        const std::string keyword(tokens[0]);
        if (kKeywords.count(keyword) == 0) {
            cloud_line_error(name, cursor->line_number(),
                             "unknown PCD header keyword \"" + keyword.substr(0, 40) +
                                 "\" (expected VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, "
                                 "HEIGHT, VIEWPOINT, POINTS or DATA)");
        }
        if (lines.count(keyword) != 0) {
            cloud_line_error(name, cursor->line_number(), keyword + " appears twice");
        }
        lines[keyword] = {std::vector<std::string_view>(tokens.begin() + 1, tokens.end()),
                          cursor->line_number()};
        if (keyword == "DATA") return lines;
    }
    cloud_error(name, bytes.empty() ? "empty file (expected a PCD header)"
                                    : "no DATA line: the PCD header is truncated or this is "
                                      "not a PCD file");
}

class HeaderParser {
public:
    HeaderParser(const std::string& name, std::map<std::string, HeaderLine> lines)
        : name_(name), lines_(std::move(lines)) {}

    PcdHeader parse();

private:
    void problem(const std::string& keyword, const std::string& what) {
        const auto it = lines_.find(keyword);
        problems_.push_back((it != lines_.end() ? "line " + std::to_string(it->second.line) + ": "
                                                : std::string()) +
                            what);
    }
    const HeaderLine* get(const std::string& keyword, bool required);
    std::uint64_t single_count(const std::string& keyword, bool required, std::uint64_t fallback);
    void parse_version();
    void parse_fields(PcdHeader* header);
    void parse_field_types(PcdHeader* header);
    void parse_viewpoint(PcdHeader* header);
    void parse_data(PcdHeader* header);
    void check_fields(PcdHeader* header);

    const std::string& name_;
    std::map<std::string, HeaderLine> lines_;
    std::vector<std::string> problems_;
};

const HeaderLine* HeaderParser::get(const std::string& keyword, bool required) {
    const auto it = lines_.find(keyword);
    if (it != lines_.end()) return &it->second;
    if (required) problem(keyword, "no " + keyword + " line");
    return nullptr;
}

std::uint64_t HeaderParser::single_count(const std::string& keyword, bool required,
                                         std::uint64_t fallback) {
    const HeaderLine* line = get(keyword, required);
    if (!line) return fallback;
    std::uint64_t value = 0;
    if (line->values.size() != 1 || !parse_count(line->values[0], &value)) {
        problem(keyword, keyword + " must be one non-negative integer");
        return fallback;
    }
    return value;
}

void HeaderParser::parse_version() {
    const HeaderLine* line = get("VERSION", false);
    if (!line) return;
    static const std::set<std::string_view> kVersions = {"0.5", "0.6", "0.7", ".5", ".6", ".7"};
    if (line->values.size() != 1 || kVersions.count(line->values[0]) == 0) {
        problem("VERSION", "unsupported VERSION (expected 0.5, 0.6 or 0.7)");
    }
}

void HeaderParser::parse_fields(PcdHeader* header) {
    const HeaderLine* line = lines_.count("FIELDS") ? get("FIELDS", true) : get("COLUMNS", false);
    if (!line) {
        problem("FIELDS", "no FIELDS line");
        return;
    }
    if (line->values.empty()) problem("FIELDS", "FIELDS names no field");
    for (const auto& field_name : line->values) {
        PcdField field;
        field.name = std::string(field_name);
        header->fields.push_back(std::move(field));
    }
}

void HeaderParser::parse_field_types(PcdHeader* header) {
    const HeaderLine* sizes = get("SIZE", true);
    const HeaderLine* types = get("TYPE", true);
    const HeaderLine* counts = get("COUNT", false);
    const std::size_t n = header->fields.size();
    for (const auto* line : {sizes, types, counts}) {
        if (line && line->values.size() != n) {
            const std::string keyword = line == sizes ? "SIZE" : line == types ? "TYPE" : "COUNT";
            problem(keyword, keyword + " has " + std::to_string(line->values.size()) +
                                 " values for " + std::to_string(n) + " FIELDS");
            return;
        }
    }
    if (!sizes || !types) return;
    for (std::size_t i = 0; i < n; ++i) {
        PcdField& field = header->fields[i];
        const std::string_view type = types->values[i];
        std::uint64_t size = 0;
        const bool size_ok = parse_count(sizes->values[i], &size) && size <= 8;
        field.type.size = size_ok ? size : 0;
        field.type.kind = type == "F"   ? ScalarKind::kFloat
                          : type == "I" ? ScalarKind::kSigned
                                        : ScalarKind::kUnsigned;
        if (!size_ok || (type != "F" && type != "I" && type != "U") || !is_supported(field.type)) {
            problem("TYPE", "field " + field.name + ": unsupported TYPE " + std::string(type) +
                                " with SIZE " + std::string(sizes->values[i]) +
                                " (expected I or U with SIZE 1, 2, 4, 8, or F with SIZE 4, 8)");
        }
        if (counts && (!parse_count(counts->values[i], &field.count) || field.count == 0 ||
                       field.count > kPcdMaxPointBytes)) {
            problem("COUNT", "field " + field.name + ": COUNT must be an integer from 1 to " +
                                 std::to_string(kPcdMaxPointBytes));
            field.count = 1;
        }
    }
}

void HeaderParser::parse_viewpoint(PcdHeader* header) {
    const HeaderLine* line = get("VIEWPOINT", false);
    if (!line) return;
    double v[7] = {};
    bool ok = line->values.size() == 7;
    for (std::size_t i = 0; ok && i < 7; ++i) {
        ok = parse_scalar_text(line->values[i], {ScalarKind::kFloat, 8}, &v[i]) &&
             std::isfinite(v[i]);
    }
    if (!ok) {
        problem("VIEWPOINT", "VIEWPOINT must be 7 finite numbers: tx ty tz qw qx qy qz");
        return;
    }
    Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > 1e-3) {
        problem("VIEWPOINT", "VIEWPOINT quaternion (qw qx qy qz) must have unit length, norm is " +
                                 std::to_string(q.norm()));
        return;
    }
    header->T_viewpoint.linear() = q.normalized().toRotationMatrix();
    header->T_viewpoint.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
}

void HeaderParser::parse_data(PcdHeader* header) {
    const HeaderLine& line = lines_.at("DATA");
    const std::string_view kind = line.values.size() == 1 ? line.values[0] : "";
    if (kind == "ascii") {
        header->data = PcdData::kAscii;
    } else if (kind == "binary") {
        header->data = PcdData::kBinary;
    } else if (kind == "binary_compressed") {
        header->data = PcdData::kBinaryCompressed;
    } else {
        problem("DATA", "unsupported DATA (expected ascii, binary or binary_compressed)");
    }
    header->data_line = line.line;
}

void HeaderParser::check_fields(PcdHeader* header) {
    std::set<std::string> seen;
    std::uint64_t offset = 0, values = 0;
    for (auto& field : header->fields) {
        if (field.name != "_" && !seen.insert(field.name).second) {
            problem("FIELDS", "field " + field.name + " appears twice");
        }
        field.offset = offset;
        field.value_index = values;
        offset += field.type.size * field.count;  // both <= 2^20: no overflow
        values += field.count;
        if (offset > kPcdMaxPointBytes) {
            problem("SIZE", "a point of more than " + std::to_string(kPcdMaxPointBytes) +
                                " bytes (SIZE x COUNT summed over FIELDS)");
            return;
        }
    }
    header->point_size = offset;
    header->values_per_point = values;
    for (const char* axis : {"x", "y", "z"}) {
        const PcdField* field = header->find(axis);
        if (!field) {
            problem("FIELDS", std::string("no field ") + axis + " (expected x, y and z)");
        } else if (field->type.kind != ScalarKind::kFloat || field->count != 1) {
            problem("TYPE",
                    std::string("field ") + axis + " must be TYPE F, SIZE 4 or 8, COUNT 1 (it is " +
                        scalar_name(field->type) + " x " + std::to_string(field->count) + ")");
        }
    }
    const PcdField* intensity = header->find("intensity");
    if (intensity && intensity->count != 1) problem("COUNT", "field intensity must have COUNT 1");
}

PcdHeader HeaderParser::parse() {
    PcdHeader header;
    parse_version();
    parse_fields(&header);
    parse_field_types(&header);
    header.width = single_count("WIDTH", true, 0);
    header.height = single_count("HEIGHT", false, 1);
    parse_viewpoint(&header);
    parse_data(&header);
    if (problems_.empty()) check_fields(&header);
    if (problems_.empty()) {
        const std::uint64_t organised =
            checked_product(header.width, header.height, name_, "WIDTH x HEIGHT");
        header.points = single_count("POINTS", false, organised);
        if (header.points != organised) {
            problem("POINTS", "POINTS " + std::to_string(header.points) +
                                  " is not WIDTH x HEIGHT = " + std::to_string(organised));
        }
    }
    if (!problems_.empty()) {
        // Every problem up to a dozen (a header of a thousand bad fields stays readable).
        constexpr std::size_t kListed = 12;
        std::string all = "bad PCD header: " + problems_[0];
        for (std::size_t i = 1; i < std::min(problems_.size(), kListed); ++i) {
            all += "; " + problems_[i];
        }
        if (problems_.size() > kListed) {
            all += "; and " + std::to_string(problems_.size() - kListed) + " more";
        }
        cloud_error(name_, all);
    }
    return header;
}

}  // namespace

const PcdField* PcdHeader::find(const std::string& field_name) const {
    for (const auto& field : fields) {
        if (field.name == field_name) return &field;
    }
    return nullptr;
}

PcdHeader parse_pcd_header(const std::string& bytes, const std::string& name) {
    TextCursor cursor(bytes, 0, 1);
    HeaderParser parser(name, read_header_lines(bytes, name, &cursor));
    PcdHeader header = parser.parse();
    header.data_offset = cursor.offset();
    return header;
}

}  // namespace lidarfuse::io
