#pragma once
// Per-pixel xyz lookup table for Ouster range images, following Ouster's documented
// projection (software user manual, "Lidar Range to XYZ"):
//
//   for beam (row) i and measurement id (staggered column) m of W:
//     theta_encoder = 2 pi (1 - m / W)              encoder angle
//     theta_azimuth = -2 pi beam_azimuth_angles[i] / 360
//     phi           =  2 pi beam_altitude_angles[i] / 360
//     n             = |(beam_to_lidar_transform translation x, z)|  (beam origin offset)
//     x_l = (r - n) cos(theta_e + theta_a) cos(phi) + beam_to_lidar[0,3] cos(theta_e)
//     y_l = (r - n) sin(theta_e + theta_a) cos(phi) + beam_to_lidar[0,3] sin(theta_e)
//     z_l = (r - n) sin(phi)                        + beam_to_lidar[2,3]
//   then p_sensor = lidar_to_sensor_transform * p_lidar, with mm converted to metres.
//
// Expanded, every pixel is affine in the range: p = offset + range_m * direction, so
// projecting a scan is one multiply-add per coordinate. Range 0 means "no return": callers
// skip such pixels (project() writes NaN there). Output frame: the Ouster sensor frame,
// metres. Pixel index = row * W + measurement_id, i.e. the staggered image layout the
// packets deliver (use destagger.hpp for image-space algorithms).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::ouster {

struct XyzLut {
    int width = 0;   // columns_per_frame
    int height = 0;  // pixels_per_column
    // Row-major (H*W) x 3, metres per metre of range (unit vectors in the sensor frame).
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> direction;
    // Row-major (H*W) x 3, metres; the point a zero-length range would map to.
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> offset;

    std::size_t size() const { return static_cast<std::size_t>(width) * height; }
    // Point of one pixel for a range in millimetres (no check for range 0).
    Eigen::Vector3d point(int row, int measurement_id, std::uint32_t range_mm) const {
        const Eigen::Index i = static_cast<Eigen::Index>(row) * width + measurement_id;
        return offset.row(i).transpose() + (range_mm * 1e-3) * direction.row(i).transpose();
    }
};

// Builds the table from explicit intrinsics. Angles in degrees, transforms in mm.
XyzLut make_xyz_lut(int width, int height, const std::vector<double>& beam_altitude_angles_deg,
                    const std::vector<double>& beam_azimuth_angles_deg,
                    const Eigen::Matrix4d& beam_to_lidar_transform,
                    const Eigen::Matrix4d& lidar_to_sensor_transform);

// Builds the table for a sensor (W = columns_per_frame, H = pixels_per_column).
XyzLut make_xyz_lut(const SensorInfo& info);

// Projects a staggered H x W range image (mm, row-major) into `xyz_m` (H*W entries, must
// be preallocated by the caller). Pixels with range 0 get NaN. Returns the number of
// pixels with a return. No allocation.
std::size_t project(const XyzLut& lut, const std::uint32_t* range_mm, Eigen::Vector3f* xyz_m);
std::size_t project(const XyzLut& lut, const std::uint32_t* range_mm, Eigen::Vector3d* xyz_m);

// Appends only the points with a return (range > 0), in pixel order, to `points`
// (reserve capacity H*W once to avoid reallocation). Returns the number appended.
std::size_t project_valid(const XyzLut& lut, const std::uint32_t* range_mm,
                          std::vector<Eigen::Vector3d>* points);

}  // namespace lidarfuse::ouster
