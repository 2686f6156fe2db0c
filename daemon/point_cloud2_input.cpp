#include "daemon/point_cloud2_input.hpp"

#include "drivers/io/cloud_scalar.hpp"

namespace lidarfuse::daemon {

namespace {

// sensor_msgs/PointField's datatypes.
constexpr std::uint8_t kFloat32 = 7;
constexpr std::uint8_t kFloat64 = 8;

// Where one coordinate lies in a point, and how it is stored.
struct Coordinate {
    std::uint32_t offset = 0;
    io::ScalarType type;
};

std::string field_error(const std::string& name, const std::string& what) {
    return "PointCloud2 field '" + name + "': " + what;
}

// The field `name` (x, y or z): present once, one float32 or float64, inside the point.
std::optional<std::string> find_coordinate(const PointCloud2View& cloud, const std::string& name,
                                           Coordinate* out) {
    int found = 0;
    for (const auto& f : cloud.fields) {
        if (f.name != name) continue;
        if (++found > 1) return field_error(name, "named twice, expected once");
        if (f.datatype != kFloat32 && f.datatype != kFloat64) {
            return field_error(name, "datatype " + std::to_string(f.datatype) +
                                         ", expected 7 (float32) or 8 (float64)");
        }
        // ROS drivers write count 1; 0 is read as 1 (sensor_msgs leaves it unsaid).
        if (f.count > 1) {
            return field_error(name, "count " + std::to_string(f.count) + ", expected 1");
        }
        out->type = {io::ScalarKind::kFloat, f.datatype == kFloat64 ? 8u : 4u};
        const std::uint64_t end = std::uint64_t{f.offset} + out->type.size;
        if (end > cloud.point_step) {
            return field_error(name, "ends at byte " + std::to_string(end) +
                                         ", beyond point_step " + std::to_string(cloud.point_step));
        }
        out->offset = f.offset;
    }
    if (found == 0) return field_error(name, "missing, expected x, y and z");
    return std::nullopt;
}

// height x width points of point_step bytes fit in rows of row_step, and the rows in data.
std::optional<std::string> check_sizes(const PointCloud2View& cloud) {
    const std::uint64_t row_bytes = std::uint64_t{cloud.width} * cloud.point_step;
    if (cloud.height > 1 && cloud.row_step < row_bytes) {
        return "PointCloud2 row_step " + std::to_string(cloud.row_step) + " is shorter than " +
               std::to_string(cloud.width) + " points of point_step " +
               std::to_string(cloud.point_step);
    }
    // The last row needs its points only, not its padding up to row_step.
    const std::uint64_t needed = cloud.height == 0 || cloud.width == 0
                                     ? 0
                                     : std::uint64_t{cloud.height - 1} * cloud.row_step + row_bytes;
    if (needed > cloud.data_size) {
        return "PointCloud2 data holds " + std::to_string(cloud.data_size) + " bytes, " +
               std::to_string(cloud.height) + " x " + std::to_string(cloud.width) +
               " points need " + std::to_string(needed);
    }
    return std::nullopt;
}

}  // namespace

std::optional<std::string> read_point_cloud2(const PointCloud2View& cloud, PointCloud2Points* out) {
    out->points.clear();
    out->non_finite = 0;
    Coordinate xyz[3];
    const char* names[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) {
        if (auto error = find_coordinate(cloud, names[k], &xyz[k])) return error;
    }
    if (auto error = check_sizes(cloud)) return error;
    const auto read = [&](const std::uint8_t* point, const Coordinate& c) {
        return io::decode_scalar(point + c.offset, c.type, cloud.is_bigendian);
    };
    out->points.reserve(std::size_t{cloud.height} * cloud.width);
    for (std::uint32_t r = 0; r < cloud.height; ++r) {
        const std::uint8_t* row = cloud.data + std::size_t{r} * cloud.row_step;
        for (std::uint32_t i = 0; i < cloud.width; ++i) {
            const std::uint8_t* point = row + std::size_t{i} * cloud.point_step;
            const Eigen::Vector3d p(read(point, xyz[0]), read(point, xyz[1]), read(point, xyz[2]));
            if (p.allFinite())
                out->points.push_back(p);
            else
                ++out->non_finite;
        }
    }
    return std::nullopt;
}

}  // namespace lidarfuse::daemon
