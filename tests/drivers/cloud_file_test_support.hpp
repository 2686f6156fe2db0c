#pragma once
// Helpers of the point-cloud file tests (cloud_file_test, cloud_pcd_reader_test,
// cloud_ply_reader_test): bytes of a file, values appended in a byte order, random float32
// clouds with planted bad points, exact comparison, and the message of an expected error.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include "drivers/io/cloud_file.hpp"

namespace lidarfuse::io::cloud_test {

namespace fs = std::filesystem;

inline constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
inline constexpr float kInf = std::numeric_limits<float>::infinity();

inline std::string file_bytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// Appends `value` in the given byte order (the tests build binary PCD / PLY by hand).
template <typename T>
inline void put(std::string* out, T value, bool big_endian = false) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    std::uint16_t probe = 1;
    const bool host_little = *reinterpret_cast<unsigned char*>(&probe) == 1;
    for (std::size_t i = 0; i < sizeof(T); ++i) {
        const std::size_t k = (host_little != big_endian) ? i : sizeof(T) - 1 - i;
        out->push_back(static_cast<char>(bytes[k]));
    }
}

template <typename... T>
inline void put_all(std::string* out, bool big_endian, T... values) {
    (put(out, values, big_endian), ...);
}

// Points whose coordinates are float32 values (so every encoding can keep them exactly):
// a wide range, plus values that test the ascii digits (denormal, FLT_MAX, -0 in one axis).
inline CloudFile random_cloud(std::uint32_t seed, std::size_t n, bool with_intensity) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> coordinate(-250.0f, 250.0f);
    std::uniform_real_distribution<float> intensity(0.0f, 4096.0f);
    CloudFile cloud;
    for (std::size_t i = 0; i < n; ++i) {
        const float x = coordinate(rng), y = coordinate(rng), z = coordinate(rng);  // in order
        cloud.cloud.points.emplace_back(x, y, z);
        if (with_intensity) cloud.intensity.push_back(intensity(rng));
    }
    if (n >= 4) {
        using V = Eigen::Vector3d;
        cloud.cloud.points[1] = V(std::numeric_limits<float>::denorm_min(), -0.0f, 1e-30f);
        cloud.cloud.points[2] = V(std::numeric_limits<float>::max(), -1.17549435e-38f, 0.1f);
        cloud.cloud.points[3] = V(0.0f, 0.0f, 3.0f);  // zero in two axes only: kept
    }
    return cloud;
}

// Every bad point kind inserted at a known place, and the cloud a reader must return.
struct Planted {
    CloudFile written;
    CloudFile expected;
    std::size_t bad = 0;
};

inline Planted with_bad_points(const CloudFile& good) {
    using V = Eigen::Vector3d;
    const std::vector<V> bad = {V(kNan, 1, 2), V(1, kInf, 2),    V(1, 2, -kInf),
                                V(0, 0, 0),    V(-0.0, 0, -0.0), V(kNan, kNan, kNan)};
    Planted p;
    p.expected = good;
    for (std::size_t i = 0; i < good.cloud.points.size(); ++i) {
        if (i % 7 == 0 && p.bad < bad.size()) {
            p.written.cloud.points.push_back(bad[p.bad++]);
            if (!good.intensity.empty()) p.written.intensity.push_back(99.0f);
        }
        p.written.cloud.points.push_back(good.cloud.points[i]);
        if (!good.intensity.empty()) p.written.intensity.push_back(good.intensity[i]);
    }
    return p;
}

inline void expect_same_cloud(const CloudFile& got, const CloudFile& expected) {
    ASSERT_EQ(got.cloud.points.size(), expected.cloud.points.size());
    ASSERT_EQ(got.intensity.size(), expected.intensity.size());
    for (std::size_t i = 0; i < got.cloud.points.size(); ++i) {
        // Exact: float32 in, float32 out, whatever the encoding.
        ASSERT_EQ(got.cloud.points[i], expected.cloud.points[i]) << "point " << i;
        if (!got.intensity.empty()) {
            ASSERT_EQ(got.intensity[i], expected.intensity[i]) << "point " << i;
        }
    }
}

inline std::string error_of(const std::function<void()>& run) {
    try {
        run();
    } catch (const std::runtime_error& error) {
        return error.what();
    }
    return "(no error)";
}

inline std::string replaced(std::string bytes, const std::string& from, const std::string& to) {
    const auto at = bytes.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) bytes.replace(at, from.size(), to);
    return bytes;
}

// Where the binary data starts (after the DATA line).
inline std::size_t data_start(const std::string& bytes) {
    return bytes.find('\n', bytes.find("\nDATA ") + 1) + 1;
}

}  // namespace lidarfuse::io::cloud_test
