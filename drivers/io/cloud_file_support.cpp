#include "drivers/io/cloud_file_support.hpp"

#include <fstream>
#include <limits>
#include <stdexcept>

namespace lidarfuse::io {

void cloud_error(const std::string& name, const std::string& what) {
    throw std::runtime_error(name + ": " + what);
}

void cloud_line_error(const std::string& name, std::size_t line, const std::string& what) {
    throw std::runtime_error(name + ":" + std::to_string(line) + ": " + what);
}

std::uint64_t checked_product(std::uint64_t a, std::uint64_t b, const std::string& name,
                              const std::string& what) {
    if (a != 0 && b > std::numeric_limits<std::uint64_t>::max() / a) {
        cloud_error(name, what + " (" + std::to_string(a) + " x " + std::to_string(b) +
                              ") overflows 64 bits");
    }
    return a * b;
}

CloudBuilder::CloudBuilder(bool has_intensity, const Eigen::Isometry3d& T_frame_file)
    : has_intensity_(has_intensity),
      identity_(T_frame_file.matrix() == Eigen::Matrix4d::Identity()),
      T_frame_file_(T_frame_file) {}

void CloudBuilder::reserve(std::size_t points) {
    result_.cloud.points.reserve(points);
    if (has_intensity_) result_.intensity.reserve(points);
}

std::string read_file_bytes(const std::filesystem::path& file) {
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec)) cloud_error(file.string(), "is a directory");
    std::ifstream in(file, std::ios::binary);
    if (!in) cloud_error(file.string(), "cannot open for reading");
    std::string bytes;
    char chunk[1 << 16];
    while (in.read(chunk, sizeof(chunk)) || in.gcount() > 0) {
        bytes.append(chunk, static_cast<std::size_t>(in.gcount()));
    }
    if (in.bad()) cloud_error(file.string(), "read failed");
    return bytes;
}

void write_file_atomically(const std::filesystem::path& file, const std::string& bytes) {
    const auto temporary = file.string() + ".tmp";
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        if (!out) throw std::runtime_error(temporary + ": cannot open for writing");
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        out.flush();
        if (!out) throw std::runtime_error(temporary + ": write failed");
    }
    std::filesystem::rename(temporary, file);
}

void check_writable(const std::filesystem::path& file, const CloudFile& cloud) {
    const std::size_t n = cloud.cloud.points.size();
    if (!cloud.intensity.empty() && cloud.intensity.size() != n) {
        cloud_error(file.string(), "cannot write: " + std::to_string(cloud.intensity.size()) +
                                       " intensities for " + std::to_string(n) +
                                       " points (expected one per point or none)");
    }
}

}  // namespace lidarfuse::io
