// Ouster metadata: every sample file parses to the documented values and round-trips
// through the nested JSON form, defaults apply to old files. Broken documents:
// ouster_metadata_problems_test.cpp.

#include <gtest/gtest.h>

#include <array>
#include <cctype>
#include <string>

#include "drivers/ouster/metadata.hpp"
#include "tests/drivers/ouster_metadata_test_support.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::ouster {
namespace {

using metadata_test::Expected;
using metadata_test::has_problem;
using metadata_test::joined;
using metadata_test::kSamples;

class SampleMetadata : public ::testing::TestWithParam<Expected> {};

TEST_P(SampleMetadata, ParsesWithExpectedValues) {
    const Expected& e = GetParam();
    LIDARFUSE_REQUIRE_OUSTER_FILE(path, e.file);
    const SensorInfo info = load_metadata(path);
    EXPECT_EQ(info.prod_sn, e.serial);
    EXPECT_EQ(info.form, e.form);
    EXPECT_EQ(info.lidar_mode, e.mode);
    EXPECT_EQ(info.columns_per_frame, e.columns);
    EXPECT_EQ(info.frames_per_second, 10);
    EXPECT_EQ(info.udp_profile_lidar, e.profile) << to_string(info.udp_profile_lidar);
    EXPECT_EQ(info.pixels_per_column, e.rows);
    EXPECT_EQ(info.columns_per_packet, 16);
    EXPECT_EQ(info.udp_port_lidar, e.port_lidar);
    EXPECT_EQ(info.udp_port_imu, e.port_imu);
    EXPECT_EQ(info.column_window, e.window);
    EXPECT_EQ(info.init_id, e.init_id);
    EXPECT_DOUBLE_EQ(info.lidar_origin_to_beam_origin_mm, e.beam_origin_mm);
    EXPECT_EQ(info.beam_altitude_angles_deg.size(), static_cast<std::size_t>(e.rows));
    EXPECT_EQ(info.beam_azimuth_angles_deg.size(), static_cast<std::size_t>(e.rows));
    EXPECT_EQ(info.pixel_shift_by_row.size(), static_cast<std::size_t>(e.rows));
    // Every sample's beam origin sits on the x axis of the beam_to_lidar transform.
    EXPECT_NEAR(info.beam_to_lidar_transform(0, 3), e.beam_origin_mm, 1e-9);
    EXPECT_EQ(info.lidar_to_sensor_transform(0, 0), -1.0);
    EXPECT_EQ(info.lidar_to_sensor_transform(1, 1), -1.0);
    if (!std::string(e.serial).empty()) {
        EXPECT_EQ(info.serial_number(), std::stoull(e.serial));
    }
    EXPECT_TRUE(validate_sensor_info(info).empty()) << joined(validate_sensor_info(info));
}

TEST_P(SampleMetadata, NestedJsonRoundTrips) {
    const Expected& e = GetParam();
    LIDARFUSE_REQUIRE_OUSTER_FILE(path, e.file);
    const SensorInfo a = load_metadata(path);
    const std::string text = to_nested_json(a);
    const SensorInfo b = parse_metadata(text, "round trip");
    EXPECT_EQ(b.form, MetadataForm::kNested);
    EXPECT_EQ(b.prod_sn, a.prod_sn);
    EXPECT_EQ(b.prod_line, a.prod_line);
    EXPECT_EQ(b.prod_pn, a.prod_pn);
    EXPECT_EQ(b.build_rev, a.build_rev);
    EXPECT_EQ(b.image_rev, a.image_rev);
    EXPECT_EQ(b.status, a.status);
    EXPECT_EQ(b.init_id, a.init_id);
    EXPECT_EQ(b.lidar_mode, a.lidar_mode);
    EXPECT_EQ(b.columns_per_frame, a.columns_per_frame);
    EXPECT_EQ(b.frames_per_second, a.frames_per_second);
    EXPECT_EQ(b.pixels_per_column, a.pixels_per_column);
    EXPECT_EQ(b.columns_per_packet, a.columns_per_packet);
    EXPECT_EQ(b.udp_profile_lidar, a.udp_profile_lidar);
    EXPECT_EQ(b.udp_profile_imu, a.udp_profile_imu);
    EXPECT_EQ(b.pixel_shift_by_row, a.pixel_shift_by_row);
    EXPECT_EQ(b.column_window, a.column_window);
    EXPECT_EQ(b.beam_altitude_angles_deg, a.beam_altitude_angles_deg);  // exact doubles
    EXPECT_EQ(b.beam_azimuth_angles_deg, a.beam_azimuth_angles_deg);
    EXPECT_EQ(b.lidar_origin_to_beam_origin_mm, a.lidar_origin_to_beam_origin_mm);
    EXPECT_EQ(b.beam_to_lidar_transform, a.beam_to_lidar_transform);
    EXPECT_EQ(b.lidar_to_sensor_transform, a.lidar_to_sensor_transform);
    EXPECT_EQ(b.imu_to_sensor_transform, a.imu_to_sensor_transform);
    EXPECT_EQ(b.udp_port_lidar, a.udp_port_lidar);
    EXPECT_EQ(b.udp_port_imu, a.udp_port_imu);
    EXPECT_EQ(b.udp_dest, a.udp_dest);
    EXPECT_EQ(b.timestamp_mode, a.timestamp_mode);
    EXPECT_EQ(b.azimuth_window_mdeg, a.azimuth_window_mdeg);
    EXPECT_TRUE(b.defaults_applied.empty()) << b.defaults_applied.front();
}

INSTANTIATE_TEST_SUITE_P(AllSamples, SampleMetadata, ::testing::ValuesIn(kSamples),
                         [](const ::testing::TestParamInfo<Expected>& param_info) {
                             std::string name = param_info.param.file;
                             for (char& c : name) {
                                 if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                             }
                             return name;
                         });

TEST(OusterMetadata, ReducedLegacyFileGetsOusterDefaults) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(path, "OS-1-64_sensor_config_reduced.json");
    const SensorInfo info = load_metadata(path);
    EXPECT_DOUBLE_EQ(info.lidar_origin_to_beam_origin_mm, 12.163);
    Eigen::Matrix4d beam_to_lidar = Eigen::Matrix4d::Identity();
    beam_to_lidar(0, 3) = 12.163;
    EXPECT_EQ(info.beam_to_lidar_transform, beam_to_lidar);
    Eigen::Matrix4d l2s = Eigen::Matrix4d::Identity();
    l2s(0, 0) = -1;
    l2s(1, 1) = -1;
    l2s(2, 3) = 36.18;
    EXPECT_EQ(info.lidar_to_sensor_transform, l2s);
    EXPECT_EQ(info.imu_to_sensor_transform(0, 3), 6.253);
    EXPECT_EQ(info.imu_to_sensor_transform(1, 3), -11.775);
    EXPECT_EQ(info.imu_to_sensor_transform(2, 3), 7.645);
    ASSERT_EQ(info.pixel_shift_by_row.size(), 64u);
    for (int row = 0; row < 64; ++row) {
        EXPECT_EQ(info.pixel_shift_by_row[static_cast<std::size_t>(row)], 18 - 6 * (row % 4));
    }
    EXPECT_EQ(info.udp_profile_lidar, UdpProfileLidar::kLegacy);
    EXPECT_FALSE(info.defaults_applied.empty());
    EXPECT_TRUE(has_problem(info.defaults_applied, "lidar_origin_to_beam_origin_mm"));
    EXPECT_TRUE(has_problem(info.defaults_applied, "pixel_shift_by_row"));
}

TEST(OusterMetadata, DefaultsFollowProductLineAndRowCount) {
    EXPECT_DOUBLE_EQ(default_lidar_origin_to_beam_origin_mm("OS-0-128"), 27.67);
    EXPECT_DOUBLE_EQ(default_lidar_origin_to_beam_origin_mm("OS-1-64-AH"), 15.806);
    EXPECT_DOUBLE_EQ(default_lidar_origin_to_beam_origin_mm("OS-2-32-U0"), 13.762);
    EXPECT_DOUBLE_EQ(default_lidar_origin_to_beam_origin_mm(""), 12.163);
    const std::vector<int> s512 = default_pixel_shift_by_row(std::vector<double>(64, 0.0), 64, 512);
    EXPECT_EQ(std::vector<int>(s512.begin(), s512.begin() + 4), (std::vector<int>{9, 6, 3, 0}));
    // Other row counts: from the azimuth angles.
    EXPECT_EQ(default_pixel_shift_by_row({4.16, 1.33, -1.48, -4.29}, 4, 1024),
              (std::vector<int>{12, 4, -4, -12}));
    EXPECT_EQ(default_pixel_shift_by_row({1.0}, 3, 1024), (std::vector<int>{0, 0, 0}));
}

TEST(OusterMetadata, ProfileAndModeNames) {
    for (const auto p : {UdpProfileLidar::kLegacy, UdpProfileLidar::kRng19Rfl8Sig16Nir16,
                         UdpProfileLidar::kRng15Rfl8Nir8, UdpProfileLidar::kRng19Rfl8Sig16Nir16Dual,
                         UdpProfileLidar::kFusaRng15Rfl8Nir8Dual}) {
        EXPECT_EQ(udp_profile_lidar_from_string(to_string(p)), p);
    }
    EXPECT_FALSE(udp_profile_lidar_from_string("RNG99"));
    EXPECT_EQ(parse_lidar_mode("2048x10"), (std::array<int, 2>{2048, 10}));
    EXPECT_FALSE(parse_lidar_mode("2048x20"));
    EXPECT_FALSE(parse_lidar_mode(""));
}

}  // namespace
}  // namespace lidarfuse::ouster
