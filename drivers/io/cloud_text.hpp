#pragma once
// Lines and whitespace-separated tokens of a text header or an ascii body, straight from
// the file's bytes (no copies, one token vector reused per line). Line numbers are 1-based
// and count every line of the file, so an error can point at the line a user opens.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace lidarfuse::io {

class TextCursor {
public:
    // Reads `bytes` from `offset`; `first_line_number` is the file line at that offset.
    TextCursor(const std::string& bytes, std::size_t offset, std::size_t first_line_number);

    // The next line (without its '\n' / "\r\n"); false at the end of the bytes.
    bool next_line(std::string_view* line);
    // The next line that holds a token, split into `tokens`; false at the end.
    bool next_tokens(std::vector<std::string_view>* tokens);

    // 1-based number of the line last returned.
    std::size_t line_number() const { return line_number_; }
    // Byte offset just past the line last returned (where binary data would start).
    std::size_t offset() const { return pos_; }
    bool at_end() const { return pos_ >= bytes_.size(); }

private:
    const std::string& bytes_;
    std::size_t pos_;
    std::size_t line_number_;
};

// Splits a line at spaces, tabs, '\r', '\v' and '\f'.
void split_tokens(std::string_view line, std::vector<std::string_view>* tokens);

}  // namespace lidarfuse::io
