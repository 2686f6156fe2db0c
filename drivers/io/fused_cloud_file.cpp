#include "drivers/io/fused_cloud_file.hpp"

#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lidarfuse::io {

namespace {

// x y z intensity (float), sensor dynamic (uchar): the record both formats write.
constexpr std::size_t kPlyRecordBytes = 4 * 4 + 2;

// `header`, then the points' 18-byte records, into a temporary file renamed to `file`.
void write_fused_cloud(const std::filesystem::path& file, const std::string& header,
                       const core::FusedCloud& cloud) {
    const std::size_t n = cloud.points.size();
    if (cloud.intensity.size() != n || cloud.sensor.size() != n || cloud.dynamic.size() != n) {
        throw std::runtime_error(file.string() +
                                 ": fused cloud attributes do not match its points");
    }
    const auto temporary = file.string() + ".tmp";
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        if (!out) throw std::runtime_error(temporary + ": cannot open for writing");
        out << header;
        char record[18];
        for (std::size_t i = 0; i < n; ++i) {
            std::memcpy(record, cloud.points[i].data(), 12);  // x86/ARM little endian
            std::memcpy(record + 12, &cloud.intensity[i], 4);
            record[16] = static_cast<char>(cloud.sensor[i]);
            record[17] = static_cast<char>(cloud.dynamic[i]);
            out.write(record, sizeof(record));
        }
        out.flush();
        if (!out) throw std::runtime_error(temporary + ": write failed");
    }
    std::filesystem::rename(temporary, file);
}

}  // namespace

void write_fused_cloud_ply(const std::filesystem::path& file, const core::FusedCloud& cloud) {
    const std::string n = std::to_string(cloud.points.size());
    write_fused_cloud(file,
                      "ply\nformat binary_little_endian 1.0\ncomment lidarfuse fused cloud, fused "
                      "frame, metres\nelement vertex " +
                          n +
                          "\nproperty float x\nproperty float y\nproperty float z\n"
                          "property float intensity\nproperty uchar sensor\nproperty uchar "
                          "dynamic\nend_header\n",
                      cloud);
}

void write_fused_cloud_pcd(const std::filesystem::path& file, const core::FusedCloud& cloud) {
    const std::string n = std::to_string(cloud.points.size());
    write_fused_cloud(file,
                      "# .PCD v0.7 - lidarfuse fused cloud, fused frame, metres\nVERSION 0.7\n"
                      "FIELDS x y z intensity sensor_id dynamic\nSIZE 4 4 4 4 1 1\n"
                      "TYPE F F F F U U\nCOUNT 1 1 1 1 1 1\nWIDTH " +
                          n + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n +
                          "\nDATA binary\n",
                      cloud);
}

core::FusedCloud read_fused_cloud_ply(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw std::runtime_error(file.string() + ": cannot open");
    const auto fail = [&](const std::string& why) {
        return std::runtime_error(file.string() + ": " + why);
    };
    std::string line;
    std::getline(in, line);
    if (line != "ply") throw fail("not a PLY file");
    const std::vector<std::string> properties = {
        "property float x",         "property float y",      "property float z",
        "property float intensity", "property uchar sensor", "property uchar dynamic"};
    std::size_t vertices = 0, property = 0;
    bool have_format = false, have_vertices = false;
    while (std::getline(in, line)) {
        if (line == "end_header") break;
        if (line.rfind("comment", 0) == 0) continue;
        if (line.rfind("format ", 0) == 0) {
            if (line != "format binary_little_endian 1.0")
                throw fail("unsupported \"" + line + "\"");
            have_format = true;
        } else if (line.rfind("element vertex ", 0) == 0) {
            vertices = std::stoull(line.substr(15));
            have_vertices = true;
        } else if (property < properties.size() && line == properties[property]) {
            ++property;
        } else {
            throw fail("unexpected header line \"" + line + "\" (not a lidarfuse fused cloud)");
        }
    }
    if (line != "end_header" || !have_format || !have_vertices || property != properties.size()) {
        throw fail("incomplete header (not a lidarfuse fused cloud)");
    }
    std::vector<char> data(vertices * kPlyRecordBytes);
    in.read(data.data(), static_cast<std::streamsize>(data.size()));
    if (static_cast<std::size_t>(in.gcount()) != data.size()) {
        throw fail("truncated: " + std::to_string(vertices) + " vertices announced");
    }
    core::FusedCloud cloud;
    cloud.points.resize(vertices);
    cloud.intensity.resize(vertices);
    cloud.sensor.resize(vertices);
    cloud.dynamic.resize(vertices);
    for (std::size_t i = 0; i < vertices; ++i) {
        const char* v = data.data() + i * kPlyRecordBytes;
        float f[4];
        std::memcpy(f, v, sizeof(f));  // little-endian host (x86-64, aarch64)
        cloud.points[i] = Eigen::Vector3f(f[0], f[1], f[2]);
        cloud.intensity[i] = f[3];
        cloud.sensor[i] = static_cast<std::uint8_t>(v[16]);
        cloud.dynamic[i] = static_cast<std::uint8_t>(v[17]);
    }
    return cloud;
}

}  // namespace lidarfuse::io
