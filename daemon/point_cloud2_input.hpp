#pragma once
// A sensor_msgs/PointCloud2 as points for fusion: the reading side of clouds that come from
// DDS instead of Ouster UDP (another station's fused cloud, or any ROS 2 LiDAR driver's).
//
// Any field layout is read: x, y and z (float32 or float64, one element each) at the
// offsets the message names, in either byte order, over height x width points with
// row_step and point_step as given; every other field is ignored. A point with a
// non-finite coordinate is skipped and counted (ROS drivers mark "no return" that way). A
// message whose layout cannot be read (a coordinate missing, twice or of another type, an
// offset beyond the point, rows or data too short for the counts) gives an error naming
// the field or size and what was expected; nothing is read from it.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

// The message as Cyclone DDS's generated C type (sensor_msgs.h); only view_of() reads it,
// so the reader itself builds without the generated types (fuzzers, tests).
struct sensor_msgs_msg_dds__PointCloud2_;

namespace lidarfuse::daemon {

// One entry of PointCloud2.fields; datatype as sensor_msgs/PointField (7 float32, 8 float64).
struct PointCloud2Field {
    std::string name;
    std::uint32_t offset = 0;
    std::uint8_t datatype = 0;
    std::uint32_t count = 1;
};

// What a PointCloud2 message says, without the DDS types (so that tests and fuzzers can
// build one). `data` is not owned.
struct PointCloud2View {
    std::int64_t stamp_ns = 0;  // header.stamp
    std::string frame_id;       // header.frame_id
    std::uint32_t height = 0;
    std::uint32_t width = 0;
    std::vector<PointCloud2Field> fields;
    bool is_bigendian = false;
    std::uint32_t point_step = 0;  // bytes per point
    std::uint32_t row_step = 0;    // bytes per row
    const std::uint8_t* data = nullptr;
    std::size_t data_size = 0;
};

// The view of a message as Cyclone DDS hands it to a reader; valid while `message` is
// (daemon/point_cloud2_view.cpp).
PointCloud2View view_of(const sensor_msgs_msg_dds__PointCloud2_& message);

struct PointCloud2Points {
    std::vector<Eigen::Vector3d> points;  // in header.frame_id, metres
    std::size_t non_finite = 0;           // points skipped: a coordinate NaN or infinite
};

// The finite points of `cloud` into `out` (its buffers reused). nullopt when read; else
// why the message cannot be read, and `out` holds no points.
std::optional<std::string> read_point_cloud2(const PointCloud2View& cloud, PointCloud2Points* out);

}  // namespace lidarfuse::daemon
