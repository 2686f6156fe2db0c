// Reading sensor_msgs/PointCloud2 (daemon/point_cloud2_input.hpp): the daemon's own cloud
// message reads back to its points; any field layout, either byte order and row padding
// are read; non-finite points are skipped and counted; a layout that cannot be read is
// refused naming the field or size; random layouts never read outside the data.
#include "daemon/point_cloud2_input.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "daemon/dds_messages.hpp"

namespace lidarfuse::daemon {
namespace {

constexpr std::uint8_t kInt16 = sensor_msgs_msg_dds__PointField_Constants_INT16;
constexpr std::uint8_t kFloat32 = sensor_msgs_msg_dds__PointField_Constants_FLOAT32;
constexpr std::uint8_t kFloat64 = sensor_msgs_msg_dds__PointField_Constants_FLOAT64;

TEST(PointCloud2Input, TheDaemonsOwnCloudReadsBackToItsPoints) {
    FrameMessageBuilder builder({"st", "station", {"north", "east"}, 0});
    core::FusedCloud cloud;
    for (int i = 0; i < 100; ++i) {
        cloud.points.emplace_back(0.25f * i, -1.5f + 0.01f * i, 3.0f);
        cloud.intensity.push_back(static_cast<float>(i));
        cloud.sensor.push_back(static_cast<std::uint8_t>(i % 2));
        cloud.dynamic.push_back(0);
    }
    FrameStamps stamps;
    stamps.frame_ns = 1'763'700'000'123'456'789;
    const PointCloud2View view = view_of(builder.cloud(cloud, stamps));
    EXPECT_EQ(view.stamp_ns, stamps.frame_ns);
    EXPECT_EQ(view.frame_id, "station");
    PointCloud2Points read;
    ASSERT_EQ(read_point_cloud2(view, &read), std::nullopt);
    ASSERT_EQ(read.points.size(), cloud.points.size());
    EXPECT_EQ(read.non_finite, 0u);
    for (std::size_t i = 0; i < cloud.points.size(); ++i)
        EXPECT_EQ(read.points[i], cloud.points[i].cast<double>()) << i;
}

// A cloud of 2 rows x 3 points, each point: ring (uint16), then x, y, z as float64 at
// shuffled offsets, 2 bytes of padding; rows padded to 96 bytes; in the given byte order.
struct LaidOutCloud {
    std::vector<std::uint8_t> data;
    PointCloud2View view;
    std::vector<Eigen::Vector3d> points;
};

LaidOutCloud laid_out(bool big_endian) {
    LaidOutCloud c;
    c.view.height = 2;
    c.view.width = 3;
    c.view.point_step = 2 + 24 + 2;
    c.view.row_step = 96;
    c.view.is_bigendian = big_endian;
    c.view.fields = {{"ring", 0, kInt16, 1},
                     {"z", 2, kFloat64, 1},
                     {"x", 10, kFloat64, 1},
                     {"y", 18, kFloat64, 1}};
    c.data.assign(2 * 96, 0xAB);
    for (std::uint32_t r = 0; r < 2; ++r) {
        for (std::uint32_t i = 0; i < 3; ++i) {
            const Eigen::Vector3d p(1.0 + i, -2.0 * r, 0.125 * (i + 3 * r));
            c.points.push_back(p);
            std::uint8_t* at = c.data.data() + r * 96 + i * c.view.point_step;
            const std::pair<std::uint32_t, double> values[3] = {
                {10, p.x()}, {18, p.y()}, {2, p.z()}};
            for (const auto& [offset, value] : values) {
                std::uint8_t bytes[8];
                std::memcpy(bytes, &value, 8);
                if (big_endian) std::reverse(bytes, bytes + 8);
                std::memcpy(at + offset, bytes, 8);
            }
        }
    }
    c.view.data = c.data.data();
    c.view.data_size = c.data.size();
    return c;
}

TEST(PointCloud2Input, AnyLayoutAndByteOrderIsRead) {
    for (bool big_endian : {false, true}) {
        SCOPED_TRACE(big_endian ? "big endian" : "little endian");
        const LaidOutCloud c = laid_out(big_endian);
        PointCloud2Points read;
        ASSERT_EQ(read_point_cloud2(c.view, &read), std::nullopt);
        EXPECT_EQ(read.points, c.points);
    }
}

TEST(PointCloud2Input, NonFinitePointsAreSkippedAndCounted) {
    LaidOutCloud c = laid_out(false);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    std::memcpy(c.data.data() + 0 * c.view.point_step + 10, &nan, 8);      // row 0, point 0: x
    std::memcpy(c.data.data() + 96 + 2 * c.view.point_step + 2, &inf, 8);  // row 1, point 2: z
    PointCloud2Points read;
    ASSERT_EQ(read_point_cloud2(c.view, &read), std::nullopt);
    EXPECT_EQ(read.non_finite, 2u);
    ASSERT_EQ(read.points.size(), 4u);
    EXPECT_EQ(read.points.front(), c.points[1]);
    EXPECT_EQ(read.points.back(), c.points[4]);
}

// Each broken layout: its error names what is wrong, and nothing is read.
TEST(PointCloud2Input, LayoutsThatCannotBeReadAreRefusedNamingWhat) {
    struct Case {
        const char* what;
        void (*spoil)(PointCloud2View*);
        const char* error;
    };
    const Case cases[] = {
        {"no z", [](PointCloud2View* v) { v->fields.erase(v->fields.begin() + 1); },
         "field 'z': missing"},
        {"x twice",
         [](PointCloud2View* v) {
             v->fields.push_back({"x", 18, kFloat64, 1});
         },
         "field 'x': named twice"},
        {"y as int16", [](PointCloud2View* v) { v->fields[3].datatype = kInt16; },
         "field 'y': datatype 3"},
        {"x of 3", [](PointCloud2View* v) { v->fields[2].count = 3; }, "field 'x': count 3"},
        {"z past the point", [](PointCloud2View* v) { v->fields[1].offset = 24; },
         "field 'z': ends at byte 32, beyond point_step 28"},
        {"short data", [](PointCloud2View* v) { v->data_size = 96 + 3 * 28 - 1; },
         "data holds 179 bytes, 2 x 3 points need 180"},
        {"short rows", [](PointCloud2View* v) { v->row_step = 50; },
         "row_step 50 is shorter than 3 points of point_step 28"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.what);
        LaidOutCloud cloud = laid_out(false);
        c.spoil(&cloud.view);
        PointCloud2Points read;
        read.points.emplace_back(1, 2, 3);  // left from an earlier message
        const auto error = read_point_cloud2(cloud.view, &read);
        ASSERT_TRUE(error.has_value());
        EXPECT_NE(error->find(c.error), std::string::npos) << *error;
        EXPECT_TRUE(read.points.empty());
    }
}

// Random counts, steps, offsets and types over a buffer of random size: read or refused,
// never a read outside the buffer (which the sanitizer build would report).
TEST(PointCloud2Input, RandomLayoutsAreReadOrRefusedWithinTheData) {
    std::mt19937 rng(7);
    std::size_t read_ok = 0, refused = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        std::uniform_int_distribution<std::uint32_t> small(0, 40);
        std::vector<std::uint8_t> data(std::uniform_int_distribution<std::size_t>(0, 600)(rng));
        for (auto& b : data) b = static_cast<std::uint8_t>(rng());
        PointCloud2View v;
        v.height = small(rng) % 4;
        v.width = small(rng) % 12;
        v.point_step = small(rng);
        v.row_step = small(rng) * 8;
        v.is_bigendian = rng() % 2;
        for (const char* name : {"x", "y", "z", "intensity"}) {
            if (rng() % 8 == 0) continue;
            v.fields.push_back({name, small(rng), rng() % 2 ? kFloat32 : kFloat64,
                                static_cast<std::uint32_t>(rng() % 5 == 0 ? 2 : 1)});
        }
        // Some buffers exactly as long as their layout needs, at the edge of the check.
        if (trial % 3 == 0 && v.height > 0 && v.width > 0)
            data.resize(std::size_t{v.height - 1} * v.row_step +
                        std::size_t{v.width} * v.point_step);
        v.data = data.data();
        v.data_size = data.size();
        PointCloud2Points read;
        if (read_point_cloud2(v, &read)) {
            ++refused;
        } else {
            ++read_ok;
            EXPECT_EQ(read.points.size() + read.non_finite, std::size_t{v.height} * v.width);
        }
    }
    EXPECT_GT(read_ok, 50u);
    EXPECT_GT(refused, 100u);
}

}  // namespace
}  // namespace lidarfuse::daemon
