#include "drivers/io/cloud_file.hpp"

#include <algorithm>
#include <cctype>

#include "drivers/io/cloud_file_support.hpp"

namespace lidarfuse::io {

CloudFile read_pcd(const std::filesystem::path& file) {
    return read_pcd(read_file_bytes(file), file.string());
}

CloudFile read_ply(const std::filesystem::path& file) {
    return read_ply(read_file_bytes(file), file.string());
}

CloudFile read_cloud_file(const std::filesystem::path& file) {
    std::string extension = file.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (extension == ".pcd") return read_pcd(file);
    if (extension == ".ply") return read_ply(file);
    cloud_error(file.string(), "unsupported point-cloud file extension \"" +
                                   file.extension().string() + "\" (expected .pcd or .ply)");
}

}  // namespace lidarfuse::io
