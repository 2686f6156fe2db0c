#include "tools/fused_cloud_reader.hpp"

#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lidarfuse::tools {

namespace {
constexpr std::size_t kVertexBytes = 4 * 4 + 2;  // x y z intensity (float), sensor dynamic (uchar)
}  // namespace

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
    std::vector<char> data(vertices * kVertexBytes);
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
        const char* v = data.data() + i * kVertexBytes;
        float f[4];
        std::memcpy(f, v, sizeof(f));  // little-endian host (x86-64, aarch64)
        cloud.points[i] = Eigen::Vector3f(f[0], f[1], f[2]);
        cloud.intensity[i] = f[3];
        cloud.sensor[i] = static_cast<std::uint8_t>(v[16]);
        cloud.dynamic[i] = static_cast<std::uint8_t>(v[17]);
    }
    return cloud;
}

}  // namespace lidarfuse::tools
