// The projection of a scan assembled from synthetic packets (ouster_packet_rig.hpp): one
// point per return at its lookup-table position, the second return, the range floor, and
// the intensity of each point's pixel.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/xyz_lut.hpp"
#include "tests/drivers/ouster_packet_rig.hpp"

namespace lidarfuse::ouster {
namespace {

using namespace packet_rig;  // NOLINT(google-build-using-namespace): the tests' vocabulary

TEST(Projection, OnePointPerReturnAtTheLookupTablePosition) {
    const auto info = make_info(UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual);
    Rig rig(info);
    for (int c = 0; c < 64; c += 8) {
        if (c != 24) rig.send(2, c);
    }
    rig.assembler.flush();
    const LidarScan& s = rig.last;
    const XyzLut lut = make_xyz_lut(info);
    ScanCloud out;
    ASSERT_TRUE(project_scan(s, lut, {}, &out));
    ASSERT_EQ(out.cloud.size(), 16u * 56u);  // every pixel of the 7 packets has a return
    ASSERT_EQ(out.pixel_index.size(), out.cloud.size());
    for (std::size_t k = 0; k < out.cloud.size(); k += 37) {
        const int row = static_cast<int>(out.row_of(k));
        const int col = static_cast<int>(out.column_of(k));
        EXPECT_FALSE(col >= 24 && col < 32);
        const Eigen::Vector3d expected = lut.point(row, col, range_of(row, col, 2));
        EXPECT_LT((out.cloud.points[k] - expected).norm(), 1e-9);
        EXPECT_EQ(out.timestamp_ns_of(k), 2'000'000'000ull + 1000ull * col);
    }
    ProjectionParams second;
    second.second_return = true;
    second.min_range_mm = 8u * 150u;  // drops returns closer than 1.2 m
    ASSERT_TRUE(project_scan(s, lut, second, &out));
    std::size_t expected_second = 0;
    for (int row = 0; row < 16; ++row) {
        for (int col = 0; col < 64; ++col) {
            if ((col < 24 || col >= 32) && range2_of(row, col) >= 8u * 150u) ++expected_second;
        }
    }
    EXPECT_EQ(out.cloud.size(), expected_second);

    Rig single(make_info(UdpProfileLidar::kRng15Rfl8Nir8));
    single.send_frame(1);
    EXPECT_FALSE(project_scan(single.last, lut, second, &out));  // no second return
    EXPECT_TRUE(out.cloud.empty());
    const XyzLut wrong = make_xyz_lut(make_info(UdpProfileLidar::kRng15Rfl8Nir8, 16, 128));
    EXPECT_FALSE(project_scan(single.last, wrong, {}, &out));
}

// The fused cloud's intensity: the signal field where the profile has one, else
// reflectivity, pixel by pixel.
TEST(Projection, IntensityIsSignalOrElseReflectivityOfEachPointsPixel) {
    for (const auto profile :
         {UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual, UdpProfileLidar::kRng15Rfl8Nir8}) {
        const auto info = make_info(profile);
        Rig rig(info);
        rig.send_frame(3);
        const LidarScan& s = rig.last;
        const bool has_signal = !s.signal.empty();
        EXPECT_EQ(has_signal, profile == UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual);
        ScanCloud cloud;
        ASSERT_TRUE(project_scan(s, make_xyz_lut(info), {}, &cloud));
        ASSERT_FALSE(cloud.cloud.empty());
        std::vector<float> intensity;
        point_intensity(s, cloud, &intensity);
        ASSERT_EQ(intensity.size(), cloud.cloud.size());
        std::size_t nonzero = 0;
        for (std::size_t k = 0; k < intensity.size(); ++k) {
            const std::uint32_t px = cloud.pixel_index[k];
            const float expected = has_signal ? static_cast<float>(s.signal[px])
                                              : static_cast<float>(s.reflectivity[px]);
            ASSERT_EQ(intensity[k], expected) << "point " << k;
            nonzero += intensity[k] != 0.0f;
        }
        EXPECT_GT(nonzero, intensity.size() / 2) << "the test's packets carry intensities";
        // Without pixel indices the intensities are unknown: zeros, never misattributed.
        cloud.pixel_index.clear();
        point_intensity(s, cloud, &intensity);
        EXPECT_EQ(std::count(intensity.begin(), intensity.end(), 0.0f),
                  static_cast<long>(intensity.size()));
    }
}

// The daemon's scans (core::SensorScanInput) hold their points in float: the same points
// rounded once, with the same pixel indices, times and intensities as the double cloud.
TEST(Projection, InFloatEveryPointIsTheDoublePointRoundedOnce) {
    const auto info = make_info(UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual);
    Rig rig(info);
    rig.send_frame(3);
    const LidarScan& s = rig.last;
    const XyzLut lut = make_xyz_lut(info);
    ScanCloud in_double, in_float;
    std::vector<Eigen::Vector3f> points = {Eigen::Vector3f::Ones()};  // replaced, not appended
    ASSERT_TRUE(project_scan(s, lut, {}, &in_double));
    ASSERT_TRUE(project_scan(s, lut, {}, &in_float, &points));
    ASSERT_FALSE(in_double.cloud.empty());
    EXPECT_TRUE(in_float.cloud.empty());
    EXPECT_EQ(in_float.num_points, in_double.num_points);
    ASSERT_EQ(points.size(), in_double.cloud.size());
    for (std::size_t k = 0; k < points.size(); ++k) {
        ASSERT_EQ(points[k], in_double.cloud.points[k].cast<float>()) << "point " << k;
    }
    EXPECT_EQ(in_float.pixel_index, in_double.pixel_index);
    std::vector<float> times_double, times_float, intensity_double, intensity_float;
    const std::uint64_t t0 = scan_reference_time_ns(s);
    point_times_s(in_double, t0, &times_double);
    point_times_s(in_float, t0, &times_float);
    point_intensity(s, in_double, &intensity_double);
    point_intensity(s, in_float, &intensity_float);
    ASSERT_EQ(times_float.size(), points.size());
    EXPECT_EQ(times_float, times_double);
    EXPECT_EQ(intensity_float, intensity_double);
    EXPECT_GT(*std::max_element(times_float.begin(), times_float.end()), 0.0f);

    const XyzLut wrong = make_xyz_lut(make_info(UdpProfileLidar::kRng15Rfl8Nir8, 16, 128));
    EXPECT_FALSE(project_scan(s, wrong, {}, &in_float, &points));
    EXPECT_TRUE(points.empty());
    EXPECT_EQ(in_float.num_points, 0u);
}

}  // namespace
}  // namespace lidarfuse::ouster
