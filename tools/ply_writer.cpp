#include "tools/ply_writer.hpp"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace lidarfuse::tools {

void write_ply(const std::filesystem::path& file, const std::vector<Eigen::Vector3d>& points,
               const std::string& comment) {
    static_assert(sizeof(float) == 4, "PLY float is 4 bytes");
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write " + file.string());
    out << "ply\nformat binary_little_endian 1.0\n";
    if (!comment.empty()) {
        std::string line = comment;
        for (char& c : line) {
            if (c == '\n' || c == '\r') c = ' ';
        }
        out << "comment " << line << "\n";
    }
    out << "element vertex " << points.size() << "\n"
        << "property float x\nproperty float y\nproperty float z\nend_header\n";
    std::vector<char> buffer(points.size() * 12);
    char* p = buffer.data();
    for (const auto& pt : points) {
        for (int k = 0; k < 3; ++k) {
            const float v = static_cast<float>(pt[k]);
            std::uint32_t bits = 0;
            std::memcpy(&bits, &v, 4);
            for (int b = 0; b < 4; ++b) *p++ = static_cast<char>((bits >> (8 * b)) & 0xFFu);
        }
    }
    out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    if (!out) throw std::runtime_error("error writing " + file.string());
}

}  // namespace lidarfuse::tools
