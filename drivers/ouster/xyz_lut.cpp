// Precomputes Ouster's range -> xyz projection as an affine map per pixel.

#include "drivers/ouster/xyz_lut.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace lidarfuse::ouster {

XyzLut make_xyz_lut(int width, int height, const std::vector<double>& beam_altitude_angles_deg,
                    const std::vector<double>& beam_azimuth_angles_deg,
                    const Eigen::Matrix4d& beam_to_lidar_transform,
                    const Eigen::Matrix4d& lidar_to_sensor_transform) {
    if (width <= 0 || height <= 0 ||
        beam_altitude_angles_deg.size() != static_cast<std::size_t>(height) ||
        beam_azimuth_angles_deg.size() != static_cast<std::size_t>(height)) {
        throw std::invalid_argument(
            "make_xyz_lut: need width, height > 0 and one altitude and "
            "azimuth angle per row (got " +
            std::to_string(beam_altitude_angles_deg.size()) + " and " +
            std::to_string(beam_azimuth_angles_deg.size()) + " for " + std::to_string(height) +
            " rows)");
    }
    constexpr double kPi = 3.14159265358979323846;
    constexpr double kMmToM = 1e-3;
    // Beam origin: x and z translation of beam_to_lidar (mm); n is its distance from the
    // lidar origin, measured along each beam.
    const double beam_x_mm = beam_to_lidar_transform(0, 3);
    const double beam_z_mm = beam_to_lidar_transform(2, 3);
    const double n_mm = std::hypot(beam_x_mm, beam_z_mm);
    const Eigen::Matrix3d r_sensor_lidar = lidar_to_sensor_transform.topLeftCorner<3, 3>();
    const Eigen::Vector3d t_sensor_lidar_mm = lidar_to_sensor_transform.topRightCorner<3, 1>();

    XyzLut lut;
    lut.width = width;
    lut.height = height;
    const Eigen::Index n = static_cast<Eigen::Index>(width) * height;
    lut.direction.resize(n, 3);
    lut.offset.resize(n, 3);
    for (int row = 0; row < height; ++row) {
        const double azimuth_rad =
            -2.0 * kPi * beam_azimuth_angles_deg[static_cast<std::size_t>(row)] / 360.0;
        const double altitude_rad =
            2.0 * kPi * beam_altitude_angles_deg[static_cast<std::size_t>(row)] / 360.0;
        const double cos_alt = std::cos(altitude_rad);
        const double sin_alt = std::sin(altitude_rad);
        for (int m = 0; m < width; ++m) {
            const double encoder_rad = 2.0 * kPi * (1.0 - static_cast<double>(m) / width);
            const double angle = encoder_rad + azimuth_rad;
            const Eigen::Vector3d dir_lidar(std::cos(angle) * cos_alt, std::sin(angle) * cos_alt,
                                            sin_alt);
            // p_lidar = (r - n) dir + beam origin rotated by the encoder, all in mm.
            const Eigen::Vector3d origin_lidar_mm(beam_x_mm * std::cos(encoder_rad),
                                                  beam_x_mm * std::sin(encoder_rad), beam_z_mm);
            const Eigen::Vector3d offset_lidar_mm = origin_lidar_mm - n_mm * dir_lidar;
            const Eigen::Index i = static_cast<Eigen::Index>(row) * width + m;
            lut.direction.row(i) = (r_sensor_lidar * dir_lidar).transpose();
            lut.offset.row(i) =
                ((r_sensor_lidar * offset_lidar_mm + t_sensor_lidar_mm) * kMmToM).transpose();
        }
    }
    return lut;
}

XyzLut make_xyz_lut(const SensorInfo& info) {
    return make_xyz_lut(info.columns_per_frame, info.pixels_per_column,
                        info.beam_altitude_angles_deg, info.beam_azimuth_angles_deg,
                        info.beam_to_lidar_transform, info.lidar_to_sensor_transform);
}

namespace {

template <typename Vec>
std::size_t project_impl(const XyzLut& lut, const std::uint32_t* range_mm, Vec* xyz_m) {
    using Scalar = typename Vec::Scalar;
    const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    const std::size_t n = lut.size();
    const double* dir = lut.direction.data();
    const double* off = lut.offset.data();
    std::size_t valid = 0;
    for (std::size_t i = 0; i < n; ++i, dir += 3, off += 3) {
        const std::uint32_t r = range_mm[i];
        if (r == 0) {
            xyz_m[i] = Vec(nan, nan, nan);
            continue;
        }
        const double r_m = r * 1e-3;
        xyz_m[i] = Vec(static_cast<Scalar>(off[0] + r_m * dir[0]),
                       static_cast<Scalar>(off[1] + r_m * dir[1]),
                       static_cast<Scalar>(off[2] + r_m * dir[2]));
        ++valid;
    }
    return valid;
}

}  // namespace

std::size_t project(const XyzLut& lut, const std::uint32_t* range_mm, Eigen::Vector3f* xyz_m) {
    return project_impl(lut, range_mm, xyz_m);
}

std::size_t project(const XyzLut& lut, const std::uint32_t* range_mm, Eigen::Vector3d* xyz_m) {
    return project_impl(lut, range_mm, xyz_m);
}

std::size_t project_valid(const XyzLut& lut, const std::uint32_t* range_mm,
                          std::vector<Eigen::Vector3d>* points) {
    const std::size_t n = lut.size();
    const double* dir = lut.direction.data();
    const double* off = lut.offset.data();
    std::size_t added = 0;
    for (std::size_t i = 0; i < n; ++i, dir += 3, off += 3) {
        const std::uint32_t r = range_mm[i];
        if (r == 0) continue;
        const double r_m = r * 1e-3;
        points->emplace_back(off[0] + r_m * dir[0], off[1] + r_m * dir[1], off[2] + r_m * dir[2]);
        ++added;
    }
    return added;
}

}  // namespace lidarfuse::ouster
