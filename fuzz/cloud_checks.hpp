#pragma once
// What fuzz_pcd_reader and fuzz_ply_reader check of one parse besides memory safety: the
// reader either returns a cloud or throws std::runtime_error whose message starts with the
// name it was given (any other exception, e.g. std::bad_alloc or std::length_error, means
// a size was not checked before use); a returned cloud holds only finite points, an
// intensity that is empty or one per point, and no more points than the input can encode
// (binary_compressed: LZF expands at most 88x, a point takes at least 12 bytes).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "drivers/io/cloud_file.hpp"
#include "fuzz/fuzz_input.hpp"

namespace lidarfuse::fuzz {

template <typename Reader>
void check_cloud_reader(const std::uint8_t* data, std::size_t size, const char* name, Reader read) {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    try {
        const io::CloudFile file = read(bytes, name);
        const auto& points = file.cloud.points;
        if (!file.intensity.empty() && file.intensity.size() != points.size()) {
            invariant_failed("intensity not one per point");
        }
        if (points.size() + file.num_dropped > 8 * size) invariant_failed("points from nowhere");
        for (const auto& p : points) {
            if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
                invariant_failed("non-finite point kept");
            }
        }
    } catch (const std::runtime_error& error) {
        if (std::strncmp(error.what(), name, std::strlen(name)) != 0) {
            invariant_failed("error message does not start with the file name");
        }
    }
}

}  // namespace lidarfuse::fuzz
