#include "drivers/io/cloud_lzf.hpp"

#include <lzf.h>

#include <algorithm>
#include <cerrno>
#include <limits>
#include <stdexcept>

#include "drivers/io/cloud_file_support.hpp"

namespace lidarfuse::io {

std::string lzf_decompress_exact(const char* data, std::size_t size, std::size_t expected_size,
                                 const std::string& name) {
    constexpr std::size_t kMax = std::numeric_limits<unsigned int>::max();
    if (size > kMax || expected_size >= kMax) {
        cloud_error(name, "LZF block larger than 4 GiB (the format stores 32-bit sizes)");
    }
    if (expected_size == 0) {
        if (size != 0) cloud_error(name, "LZF data present for an empty cloud");
        return {};
    }
    // One byte more than expected: a stream that decodes to more is told apart from one that
    // fills the buffer exactly.
    std::string out(expected_size + 1, '\0');
    errno = 0;
    const unsigned int got = lzf_decompress(data, static_cast<unsigned int>(size), out.data(),
                                            static_cast<unsigned int>(out.size()));
    if ((got == 0 && errno == E2BIG) || got > expected_size) {
        cloud_error(name, "LZF data decompresses to more than " + std::to_string(expected_size) +
                              " bytes, expected exactly that many (POINTS x point size)");
    }
    if (got == 0) {
        cloud_error(name, "corrupt LZF data (liblzf refused the " + std::to_string(size) +
                              " compressed bytes; expected them to decompress to " +
                              std::to_string(expected_size) + " bytes)");
    }
    if (got != expected_size) {
        cloud_error(name, "LZF data decompressed to " + std::to_string(got) + " bytes, expected " +
                              std::to_string(expected_size) + " (POINTS x point size)");
    }
    out.resize(expected_size);
    return out;
}

std::string lzf_literal_runs(const std::string& data) {
    constexpr std::size_t kMaxRun = 32;  // control byte 0..31 = run of 1..32 literals
    std::string out;
    out.reserve(data.size() + data.size() / kMaxRun + 1);
    for (std::size_t at = 0; at < data.size(); at += kMaxRun) {
        const std::size_t run = std::min(kMaxRun, data.size() - at);
        out.push_back(static_cast<char>(run - 1));
        out.append(data, at, run);
    }
    return out;
}

std::string lzf_compress_for_pcd(const std::string& data) {
    if (data.size() < 2) return lzf_literal_runs(data);
    if (data.size() > std::numeric_limits<unsigned int>::max()) {
        throw std::runtime_error("LZF block larger than 4 GiB");
    }
    // Room for one byte less than the input: liblzf returns 0 when it cannot shrink it.
    std::string out(data.size() - 1, '\0');
    const unsigned int size = lzf_compress(data.data(), static_cast<unsigned int>(data.size()),
                                           out.data(), static_cast<unsigned int>(out.size()));
    if (size == 0) return lzf_literal_runs(data);
    out.resize(size);
    return out;
}

}  // namespace lidarfuse::io
