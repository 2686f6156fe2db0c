#pragma once
// One numeric value as PCD and PLY store it: signed / unsigned integer of 1, 2, 4 or 8
// bytes, or an IEEE float of 4 or 8 bytes, in a given byte order (binary data) or as text
// (ascii data). Decoding assembles the value byte by byte, so it does not depend on the
// host's byte order and never reads an unaligned word.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace lidarfuse::io {

enum class ScalarKind { kSigned, kUnsigned, kFloat };

struct ScalarType {
    ScalarKind kind = ScalarKind::kFloat;
    std::size_t size = 4;  // bytes
};

// True for I/U with 1, 2, 4, 8 bytes and F with 4, 8 bytes.
bool is_supported(ScalarType type);

// "float32", "uint16" ...: for error messages.
std::string scalar_name(ScalarType type);

// The value at `p` (type.size bytes) as a double; exact for every float32 / float64 and for
// integers up to 2^53 (larger ones are rounded). `type` must be supported.
inline double decode_scalar(const unsigned char* p, ScalarType type, bool big_endian) {
    std::uint64_t bits = 0;
    if (big_endian) {
        for (std::size_t i = 0; i < type.size; ++i) bits = (bits << 8) | p[i];
    } else {
        for (std::size_t i = type.size; i-- > 0;) bits = (bits << 8) | p[i];
    }
    switch (type.kind) {
        case ScalarKind::kFloat:
            if (type.size == 4) {
                const auto word = static_cast<std::uint32_t>(bits);
                float f;
                std::memcpy(&f, &word, sizeof(f));
                return f;
            } else {
                double d;
                std::memcpy(&d, &bits, sizeof(d));
                return d;
            }
        case ScalarKind::kUnsigned:
            return static_cast<double>(bits);
        case ScalarKind::kSigned: {
            const unsigned shift = 64 - 8 * static_cast<unsigned>(type.size);
            const auto value = static_cast<std::int64_t>(bits << shift) >> shift;
            return static_cast<double>(value);
        }
    }
    return 0.0;
}

// Appends a float32 in the given byte order.
void append_float32(std::string* out, float value, bool big_endian);

// Parses one ascii token as `type`: float32 fields are rounded from the text straight to
// float (strtof), everything else read as a double (strtod); "nan" and "inf" are accepted
// (such points are dropped later). False when the token is not entirely a number. The
// token must lie inside a NUL-terminated buffer (the strto* functions stop at whitespace,
// which ends every token, or at the terminator).
bool parse_scalar_text(std::string_view token, ScalarType type, double* value);

// A non-negative decimal integer (header counts, PLY list lengths); false on anything else,
// including overflow.
bool parse_count(std::string_view token, std::uint64_t* value);

}  // namespace lidarfuse::io
