#include "drivers/io/cloud_scalar.hpp"

#include <charconv>
#include <cstdlib>

namespace lidarfuse::io {

bool is_supported(ScalarType type) {
    if (type.kind == ScalarKind::kFloat) return type.size == 4 || type.size == 8;
    return type.size == 1 || type.size == 2 || type.size == 4 || type.size == 8;
}

std::string scalar_name(ScalarType type) {
    const char* kind = type.kind == ScalarKind::kFloat    ? "float"
                       : type.kind == ScalarKind::kSigned ? "int"
                                                          : "uint";
    return kind + std::to_string(8 * type.size);
}

void append_float32(std::string* out, float value, bool big_endian) {
    std::uint32_t bits;
    std::memcpy(&bits, &value, sizeof(bits));
    char bytes[4];
    for (int i = 0; i < 4; ++i) {
        const int shift = 8 * (big_endian ? 3 - i : i);
        bytes[i] = static_cast<char>((bits >> shift) & 0xFF);
    }
    out->append(bytes, 4);
}

bool parse_scalar_text(std::string_view token, ScalarType type, double* value) {
    if (token.empty()) return false;
    // strto* skip leading whitespace; tokens never start with it, so the parse starts at
    // the token and cannot run past its end (whitespace or the buffer's terminator).
    char* end = nullptr;
    if (type.kind == ScalarKind::kFloat && type.size == 4) {
        *value = std::strtof(token.data(), &end);
    } else {
        *value = std::strtod(token.data(), &end);
    }
    return end == token.data() + token.size();
}

bool parse_count(std::string_view token, std::uint64_t* value) {
    if (token.empty()) return false;
    const char* last = token.data() + token.size();
    const auto result = std::from_chars(token.data(), last, *value);
    return result.ec == std::errc() && result.ptr == last;
}

}  // namespace lidarfuse::io
