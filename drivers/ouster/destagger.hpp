#pragma once
// Destaggering: packets deliver a "staggered" H x W image in which column m holds what
// every beam measured at encoder position m; because each beam points at its own azimuth
// offset, a vertical structure then appears sheared. pixel_shift_by_row (from metadata,
// one shift per row, in columns) undoes that:
//
//   destaggered(row, (m + shift[row]) mod W) = staggered(row, m)
//
// and restagger is the exact inverse. Both are row-major, out-of-place, no allocation,
// and work for any pixel type. `out` must not alias `in`.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lidarfuse::ouster {

namespace detail {
// Positive modulo: result in [0, w).
inline int wrap_column(long long column, int width) {
    const long long r = column % width;
    return static_cast<int>(r < 0 ? r + width : r);
}
}  // namespace detail

namespace detail {
// out(row, (m + sign * shift[row]) mod W) = in(row, m): destagger with sign +1, restagger
// (its inverse) with sign -1.
template <typename T>
void shift_rows(const T* in, int height, int width, const std::vector<int>& shift, int sign,
                T* out) {
    for (int row = 0; row < height; ++row) {
        const T* src = in + static_cast<std::size_t>(row) * width;
        T* dst = out + static_cast<std::size_t>(row) * width;
        const int s = wrap_column(static_cast<long long>(sign) * shift[row], width);
        for (int m = 0; m < width; ++m) {
            const int c = m + s < width ? m + s : m + s - width;
            dst[c] = src[m];
        }
    }
}
}  // namespace detail

// `shift` must have `height` entries; width > 0.
template <typename T>
void destagger(const T* in, int height, int width, const std::vector<int>& shift, T* out) {
    detail::shift_rows(in, height, width, shift, +1, out);
}

template <typename T>
void restagger(const T* in, int height, int width, const std::vector<int>& shift, T* out) {
    detail::shift_rows(in, height, width, shift, -1, out);
}

// Instantiated once in destagger.cpp for the LidarScan pixel types.
extern template void destagger<std::uint8_t>(const std::uint8_t*, int, int, const std::vector<int>&,
                                             std::uint8_t*);
extern template void destagger<std::uint16_t>(const std::uint16_t*, int, int,
                                              const std::vector<int>&, std::uint16_t*);
extern template void destagger<std::uint32_t>(const std::uint32_t*, int, int,
                                              const std::vector<int>&, std::uint32_t*);
extern template void destagger<float>(const float*, int, int, const std::vector<int>&, float*);
extern template void restagger<std::uint8_t>(const std::uint8_t*, int, int, const std::vector<int>&,
                                             std::uint8_t*);
extern template void restagger<std::uint16_t>(const std::uint16_t*, int, int,
                                              const std::vector<int>&, std::uint16_t*);
extern template void restagger<std::uint32_t>(const std::uint32_t*, int, int,
                                              const std::vector<int>&, std::uint32_t*);
extern template void restagger<float>(const float*, int, int, const std::vector<int>&, float*);

// Destaggered column that staggered column `measurement_id` of `row` lands in.
inline int destaggered_column(int measurement_id, int row, int width,
                              const std::vector<int>& shift) {
    return detail::wrap_column(static_cast<long long>(measurement_id) + shift[row], width);
}

}  // namespace lidarfuse::ouster
