#include "drivers/io/fused_cloud_file.hpp"

#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>

namespace lidarfuse::io {

namespace {

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

}  // namespace lidarfuse::io
