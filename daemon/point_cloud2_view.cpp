// view_of(): the generated C type of sensor_msgs/PointCloud2 as a PointCloud2View, apart
// from the reader so that the reader builds without Cyclone's generated types.
#include "daemon/point_cloud2_input.hpp"
#include "sensor_msgs.h"

namespace lidarfuse::daemon {

PointCloud2View view_of(const sensor_msgs_msg_dds__PointCloud2_& m) {
    PointCloud2View v;
    v.stamp_ns = std::int64_t{m.header.stamp.sec} * 1'000'000'000 + m.header.stamp.nanosec;
    v.frame_id = m.header.frame_id ? m.header.frame_id : "";
    v.height = m.height;
    v.width = m.width;
    for (std::uint32_t i = 0; i < m.fields._length; ++i) {
        const auto& f = m.fields._buffer[i];
        v.fields.push_back({f.name ? f.name : "", f.offset, f.datatype, f.count});
    }
    v.is_bigendian = m.is_bigendian;
    v.point_step = m.point_step;
    v.row_step = m.row_step;
    v.data = m.data._buffer;
    v.data_size = m.data._length;
    return v;
}

}  // namespace lidarfuse::daemon
