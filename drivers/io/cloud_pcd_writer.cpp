// write_pcd: x y z [intensity] as float32, v0.7 header, unorganised (HEIGHT 1), identity
// VIEWPOINT. Ascii values carry 9 significant digits, enough for every float32 to read
// back bit for bit.
#include <cstdio>
#include <limits>

#include "drivers/io/cloud_file.hpp"
#include "drivers/io/cloud_file_support.hpp"
#include "drivers/io/cloud_lzf.hpp"
#include "drivers/io/cloud_scalar.hpp"

namespace lidarfuse::io {

namespace {

const char* data_name(PcdEncoding encoding) {
    switch (encoding) {
        case PcdEncoding::kAscii:
            return "ascii";
        case PcdEncoding::kBinary:
            return "binary";
        case PcdEncoding::kBinaryCompressed:
            return "binary_compressed";
    }
    return "?";
}

std::string pcd_header(std::size_t n, bool intensity, PcdEncoding encoding) {
    const std::string count = std::to_string(n);
    std::string h = "# .PCD v0.7 - Point Cloud Data file format (lidarfuse)\nVERSION 0.7\n";
    h += intensity ? "FIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
                   : "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
    h += "WIDTH " + count + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + count + "\n";
    h += std::string("DATA ") + data_name(encoding) + "\n";
    return h;
}

// The point's values as written: float32 x, y, z and, if present, intensity.
int point_values(const CloudFile& cloud, std::size_t i, float* values) {
    const Eigen::Vector3d& p = cloud.cloud.points[i];
    values[0] = static_cast<float>(p.x());
    values[1] = static_cast<float>(p.y());
    values[2] = static_cast<float>(p.z());
    if (cloud.intensity.empty()) return 3;
    values[3] = cloud.intensity[i];
    return 4;
}

void append_ascii_rows(const CloudFile& cloud, std::string* out) {
    char text[24];
    float values[4];
    for (std::size_t i = 0; i < cloud.cloud.points.size(); ++i) {
        const int n = point_values(cloud, i, values);
        for (int k = 0; k < n; ++k) {
            const int length = std::snprintf(text, sizeof(text), "%.9g", values[k]);
            out->append(text, static_cast<std::size_t>(length));
            out->push_back(k + 1 < n ? ' ' : '\n');
        }
    }
}

void append_binary_points(const CloudFile& cloud, std::string* out) {
    float values[4];
    for (std::size_t i = 0; i < cloud.cloud.points.size(); ++i) {
        const int n = point_values(cloud, i, values);
        for (int k = 0; k < n; ++k) append_float32(out, values[k], false);
    }
}

// Field by field (struct of arrays), LZF, behind the two uint32 sizes.
void append_compressed_points(const std::filesystem::path& file, const CloudFile& cloud,
                              std::string* out) {
    const std::size_t n = cloud.cloud.points.size();
    const int fields = cloud.intensity.empty() ? 3 : 4;
    std::string columns;
    columns.reserve(n * 4 * fields);
    float values[4];
    for (int k = 0; k < fields; ++k) {
        for (std::size_t i = 0; i < n; ++i) {
            point_values(cloud, i, values);
            append_float32(&columns, values[k], false);
        }
    }
    // Half the 32-bit range: the literal-run fallback may grow the data by 1/32.
    if (columns.size() >= std::numeric_limits<std::uint32_t>::max() / 2) {
        cloud_error(file.string(), "too many points for DATA binary_compressed (32-bit sizes)");
    }
    const std::string lzf = lzf_compress_for_pcd(columns);
    for (const std::size_t size : {lzf.size(), columns.size()}) {
        for (int b = 0; b < 4; ++b) out->push_back(static_cast<char>((size >> (8 * b)) & 0xFF));
    }
    out->append(lzf);
}

}  // namespace

void write_pcd(const std::filesystem::path& file, const CloudFile& cloud, PcdEncoding encoding) {
    check_writable(file, cloud);
    const std::size_t n = cloud.cloud.points.size();
    std::string bytes = pcd_header(n, !cloud.intensity.empty(), encoding);
    switch (encoding) {
        case PcdEncoding::kAscii:
            append_ascii_rows(cloud, &bytes);
            break;
        case PcdEncoding::kBinary:
            append_binary_points(cloud, &bytes);
            break;
        case PcdEncoding::kBinaryCompressed:
            append_compressed_points(file, cloud, &bytes);
            break;
    }
    write_file_atomically(file, bytes);
}

}  // namespace lidarfuse::io
