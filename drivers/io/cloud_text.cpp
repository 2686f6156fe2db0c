#include "drivers/io/cloud_text.hpp"

#include <cstring>

namespace lidarfuse::io {

namespace {

bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f' || c == '\n';
}

}  // namespace

TextCursor::TextCursor(const std::string& bytes, std::size_t offset, std::size_t first_line_number)
    : bytes_(bytes), pos_(offset), line_number_(first_line_number - 1) {}

bool TextCursor::next_line(std::string_view* line) {
    if (pos_ >= bytes_.size()) return false;
    const char* begin = bytes_.data() + pos_;
    const std::size_t left = bytes_.size() - pos_;
    const void* newline = std::memchr(begin, '\n', left);
    const std::size_t length =
        newline ? static_cast<std::size_t>(static_cast<const char*>(newline) - begin) : left;
    *line = std::string_view(begin, length);
    if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
    pos_ += newline ? length + 1 : length;
    ++line_number_;
    return true;
}

bool TextCursor::next_tokens(std::vector<std::string_view>* tokens) {
    std::string_view line;
    while (next_line(&line)) {
        split_tokens(line, tokens);
        if (!tokens->empty()) return true;
    }
    tokens->clear();
    return false;
}

void split_tokens(std::string_view line, std::vector<std::string_view>* tokens) {
    tokens->clear();
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && is_space(line[i])) ++i;
        const std::size_t start = i;
        while (i < line.size() && !is_space(line[i])) ++i;
        if (i > start) tokens->push_back(line.substr(start, i - start));
    }
}

}  // namespace lidarfuse::io
