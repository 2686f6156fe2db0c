#pragma once
// Reading a libFuzzer input as a small header followed by length-prefixed records, so one
// input can hold a whole sequence of datagrams (or fragments) and the fuzzer can still
// splice, grow and shrink them. Records: [u16 little-endian length][bytes]; a length past
// the end of the input takes what is left. Shared by the harnesses in this folder and by
// seed_corpus.cpp, which writes inputs in the same form.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace lidarfuse::fuzz {

class FuzzInput {
public:
    FuzzInput(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

    // Next byte, or 0 once the input is exhausted.
    std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
    std::uint16_t u16() {
        const std::uint16_t lo = byte();
        return static_cast<std::uint16_t>(lo | (byte() << 8));
    }
    std::uint64_t u64() {
        std::uint64_t v = 0;
        for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(byte()) << (8 * i);
        return v;
    }

    // Next record; false when nothing is left. `*out` points into the input.
    bool record(const std::uint8_t** out, std::size_t* out_size) {
        if (pos_ + 2 > size_) return false;
        std::size_t n = u16();
        if (n > size_ - pos_) n = size_ - pos_;
        *out = data_ + pos_;
        *out_size = n;
        pos_ += n;
        return true;
    }

    std::size_t remaining() const { return size_ - pos_; }

private:
    const std::uint8_t* data_;
    std::size_t size_;
    std::size_t pos_ = 0;
};

// Appends one record in the form FuzzInput::record() reads (sizes above 65535 are cut).
inline void append_record(std::string* out, const std::uint8_t* data, std::size_t size) {
    if (size > 0xFFFF) size = 0xFFFF;
    out->push_back(static_cast<char>(size & 0xFF));
    out->push_back(static_cast<char>(size >> 8));
    out->append(reinterpret_cast<const char*>(data), size);
}

// Stops the process the way a sanitizer does, so libFuzzer saves the input: used for
// broken invariants that are not memory errors (counters that do not add up).
[[noreturn]] inline void invariant_failed(const char* what) {
    std::fprintf(stderr, "fuzz invariant failed: %s\n", what);
    std::abort();
}

}  // namespace lidarfuse::fuzz
