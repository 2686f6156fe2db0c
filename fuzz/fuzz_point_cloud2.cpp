// libFuzzer harness: a sensor_msgs/PointCloud2's layout and data into read_point_cloud2()
// (daemon/point_cloud2_input.hpp), the reader of clouds that arrive over DDS.
//
// Input (see fuzz_input.hpp): byte height, u16 width, byte point_step, u16 row_step, byte
// flags (bit 0 big endian), byte field count (mod 7), then per field: byte name (x, y, z,
// intensity, ring, or empty, mod 6), byte offset, byte datatype, byte count; the rest of
// the input is the data.
// Checked besides memory safety: a cloud is read or refused with a message about the
// PointCloud2; a read cloud accounts for every point (kept + non-finite = height x width),
// and every kept point is finite; a refused one leaves no points.
#include <cstddef>
#include <cstdint>
#include <string>

#include "daemon/point_cloud2_input.hpp"
#include "fuzz/fuzz_input.hpp"

using namespace lidarfuse;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const char* const kNames[] = {"x", "y", "z", "intensity", "ring", ""};
    fuzz::FuzzInput in(data, size);
    daemon::PointCloud2View view;
    view.height = in.byte();
    view.width = in.u16();
    view.point_step = in.byte();
    view.row_step = in.u16();
    view.is_bigendian = (in.byte() & 1) != 0;
    const int fields = in.byte() % 7;
    for (int i = 0; i < fields; ++i) {
        daemon::PointCloud2Field f;
        f.name = kNames[in.byte() % 6];
        f.offset = in.byte();
        f.datatype = in.byte();
        f.count = in.byte();
        view.fields.push_back(f);
    }
    view.data = data + (size - in.remaining());
    view.data_size = in.remaining();
    daemon::PointCloud2Points read;
    const auto error = read_point_cloud2(view, &read);
    if (error) {
        if (error->find("PointCloud2") == std::string::npos)
            fuzz::invariant_failed("a refusal that does not name the PointCloud2");
        if (!read.points.empty()) fuzz::invariant_failed("points left from a refused cloud");
        return 0;
    }
    if (read.points.size() + read.non_finite != std::size_t{view.height} * view.width)
        fuzz::invariant_failed("points not accounted for");
    for (const auto& p : read.points) {
        if (!p.allFinite()) fuzz::invariant_failed("a non-finite point kept");
    }
    return 0;
}
