// write_ply: element vertex with float x y z [intensity]. (The fused cloud with its sensor
// and dynamic flags has its own writer, cloud_ply.hpp.) Ascii values carry 9 significant
// digits, enough for every float32 to read back bit for bit.
#include <cstdio>

#include "drivers/io/cloud_file.hpp"
#include "drivers/io/cloud_file_support.hpp"
#include "drivers/io/cloud_scalar.hpp"

namespace lidarfuse::io {

namespace {

const char* format_name(PlyEncoding encoding) {
    switch (encoding) {
        case PlyEncoding::kAscii:
            return "ascii";
        case PlyEncoding::kBinaryLittleEndian:
            return "binary_little_endian";
        case PlyEncoding::kBinaryBigEndian:
            return "binary_big_endian";
    }
    return "?";
}

std::string ply_header(std::size_t n, bool intensity, PlyEncoding encoding) {
    std::string h = "ply\nformat " + std::string(format_name(encoding)) + " 1.0\n";
    h += "comment lidarfuse cloud, metres\nelement vertex " + std::to_string(n) + "\n";
    h += "property float x\nproperty float y\nproperty float z\n";
    if (intensity) h += "property float intensity\n";
    h += "end_header\n";
    return h;
}

}  // namespace

void write_ply(const std::filesystem::path& file, const CloudFile& cloud, PlyEncoding encoding) {
    check_writable(file, cloud);
    const auto& points = cloud.cloud.points;
    const bool intensity = !cloud.intensity.empty();
    std::string bytes = ply_header(points.size(), intensity, encoding);
    const bool big_endian = encoding == PlyEncoding::kBinaryBigEndian;
    char text[24];
    for (std::size_t i = 0; i < points.size(); ++i) {
        const float values[4] = {
            static_cast<float>(points[i].x()), static_cast<float>(points[i].y()),
            static_cast<float>(points[i].z()), intensity ? cloud.intensity[i] : 0.0f};
        const int n = intensity ? 4 : 3;
        for (int k = 0; k < n; ++k) {
            if (encoding != PlyEncoding::kAscii) {
                append_float32(&bytes, values[k], big_endian);
                continue;
            }
            const int length = std::snprintf(text, sizeof(text), "%.9g", values[k]);
            bytes.append(text, static_cast<std::size_t>(length));
            bytes.push_back(k + 1 < n ? ' ' : '\n');
        }
    }
    write_file_atomically(file, bytes);
}

}  // namespace lidarfuse::io
