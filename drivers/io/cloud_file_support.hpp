#pragma once
// What the cloud readers and writers share: the builder that applies the drop rule and the
// file's pose to every decoded point, whole-file reading, atomic writing, and the error
// helpers (every message starts with the file's name).

#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "drivers/io/cloud_file.hpp"

namespace lidarfuse::io {

[[noreturn]] void cloud_error(const std::string& name, const std::string& what);
// "name:LINE: what" for errors in a text line.
[[noreturn]] void cloud_line_error(const std::string& name, std::size_t line,
                                   const std::string& what);

// a * b, or an error naming `what` when the product does not fit 64 bits.
std::uint64_t checked_product(std::uint64_t a, std::uint64_t b, const std::string& name,
                              const std::string& what);

// Collects decoded points. A point with a non-finite coordinate, or exactly (0, 0, 0) in
// the file's own coordinates (a pixel without a return), is counted, not kept; kept points
// are mapped through T_frame_file (the PCD VIEWPOINT, p' = q p + t) and the intensity stays
// aligned with them.
class CloudBuilder {
public:
    CloudBuilder(bool has_intensity, const Eigen::Isometry3d& T_frame_file);

    // Reserves room for at most `points` (callers bound it by the bytes the data holds).
    void reserve(std::size_t points);
    void add(double x, double y, double z, float intensity) {
        const bool finite = std::isfinite(x) && std::isfinite(y) && std::isfinite(z);
        if (!finite || (x == 0.0 && y == 0.0 && z == 0.0)) {
            ++result_.num_dropped;
            return;
        }
        const Eigen::Vector3d p(x, y, z);
        result_.cloud.points.push_back(identity_ ? p : Eigen::Vector3d(T_frame_file_ * p));
        if (has_intensity_) result_.intensity.push_back(intensity);
    }
    CloudFile finish() { return std::move(result_); }

private:
    CloudFile result_;
    bool has_intensity_;
    bool identity_;
    Eigen::Isometry3d T_frame_file_;
};

// The whole file; an error naming it when it cannot be opened or read.
std::string read_file_bytes(const std::filesystem::path& file);

// Writes `bytes` to FILE.tmp and renames it over `file`, so a reader never sees half a file.
void write_file_atomically(const std::filesystem::path& file, const std::string& bytes);

// The writers' precondition: intensity empty or one per point.
void check_writable(const std::filesystem::path& file, const CloudFile& cloud);

}  // namespace lidarfuse::io
