// xyz lookup table: reproduces the DERIVED reference xyz of the FW 2.0 gen-1 capture and
// obeys the geometry of Ouster's documented projection.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "drivers/ouster/xyz_lut.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::ouster {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(OusterXyzLut, ReproducesDerivedReferencePoints) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta_path, "OS-1-64_sensor_config_reduced.json");
    LIDARFUSE_REQUIRE_OUSTER_FILE(ref_path, "DERIVED_OS-1-64_1024x10_fw20_reference.json");
    const SensorInfo info = load_metadata(meta_path);
    std::ifstream in(ref_path);
    const nlohmann::json ref = nlohmann::json::parse(in);
    // The reference states its assumptions; they must be the defaults we applied.
    EXPECT_DOUBLE_EQ(ref["xyz_assumptions"]["lidar_origin_to_beam_origin_mm"].get<double>(),
                     info.lidar_origin_to_beam_origin_mm);
    const auto l2s = ref["xyz_assumptions"]["lidar_to_sensor_transform"];
    for (int k = 0; k < 16; ++k) {
        EXPECT_EQ(l2s[static_cast<std::size_t>(k)].get<double>(),
                  info.lidar_to_sensor_transform(k / 4, k % 4));
    }
    const XyzLut lut = make_xyz_lut(info);
    ASSERT_EQ(lut.width, 1024);
    ASSERT_EQ(lut.height, 64);
    const auto& samples = ref["sample_pixels"];
    ASSERT_EQ(samples.size(), 12u);
    for (const auto& s : samples) {
        const int row = s["row"];
        const int col = s["col"];
        const std::uint32_t range_mm = s["range_mm"];
        const Eigen::Vector3d p = lut.point(row, col, range_mm);
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(p[k], s["xyz_sensor_m"][static_cast<std::size_t>(k)].get<double>(), 1e-6)
                << "row " << row << " col " << col << " axis " << k;
        }
    }
}

// The documented formula written out independently, for a metadata file whose beam origin
// and lidar_to_sensor differ from the defaults.
Eigen::Vector3d documented_xyz(const SensorInfo& info, int row, int m, double r_mm) {
    const double w = info.columns_per_frame;
    const double theta_e = 2 * kPi * (1 - m / w);
    const double theta_a =
        -2 * kPi * info.beam_azimuth_angles_deg[static_cast<std::size_t>(row)] / 360;
    const double phi = 2 * kPi * info.beam_altitude_angles_deg[static_cast<std::size_t>(row)] / 360;
    const double bx = info.beam_to_lidar_transform(0, 3);
    const double bz = info.beam_to_lidar_transform(2, 3);
    const double n = std::sqrt(bx * bx + bz * bz);
    const Eigen::Vector4d lidar(
        (r_mm - n) * std::cos(theta_e + theta_a) * std::cos(phi) + bx * std::cos(theta_e),
        (r_mm - n) * std::sin(theta_e + theta_a) * std::cos(phi) + bx * std::sin(theta_e),
        (r_mm - n) * std::sin(phi) + bz, 1.0);
    return (info.lidar_to_sensor_transform * lidar).head<3>() * 1e-3;
}

TEST(OusterXyzLut, MatchesDocumentedFormulaOnNestedMetadata) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta_path, "crc_test.json");  // n 27.116, z 38.195 mm
    const SensorInfo info = load_metadata(meta_path);
    const XyzLut lut = make_xyz_lut(info);
    std::mt19937 rng(3);
    for (int i = 0; i < 2000; ++i) {
        const int row = static_cast<int>(rng() % 128);
        const int m = static_cast<int>(rng() % 512);
        const std::uint32_t r = 1 + rng() % 200000;
        const Eigen::Vector3d expected = documented_xyz(info, row, m, r);
        ASSERT_LT((lut.point(row, m, r) - expected).norm(), 1e-9) << row << " " << m << " " << r;
    }
}

TEST(OusterXyzLut, GeometryOfDirectionsAndOffsets) {
    // Synthetic sensor: beam azimuth 0, altitudes spread; default transforms.
    const int w = 512;
    const int h = 16;
    std::vector<double> alt(h), az(h, 0.0);
    for (int i = 0; i < h; ++i) alt[static_cast<std::size_t>(i)] = 15.0 - 2.0 * i;
    Eigen::Matrix4d beam_to_lidar = Eigen::Matrix4d::Identity();
    beam_to_lidar(0, 3) = 15.806;
    const XyzLut lut =
        make_xyz_lut(w, h, alt, az, beam_to_lidar, default_lidar_to_sensor_transform());
    for (Eigen::Index i = 0; i < lut.direction.rows(); ++i) {
        ASSERT_NEAR(lut.direction.row(i).norm(), 1.0, 1e-12);
        const int row = static_cast<int>(i / w);
        // lidar_to_sensor keeps the z axis: z of the direction is sin(altitude).
        ASSERT_NEAR(lut.direction(i, 2), std::sin(alt[static_cast<std::size_t>(row)] * kPi / 180),
                    1e-12);
    }
    // Encoder: measurement 0 looks along lidar +x = sensor -x; a quarter turn later the
    // beam looks along lidar -y = sensor +y (the encoder angle decreases with the id).
    const int row = 7;  // altitude 1 degree
    const double c = std::cos(1.0 * kPi / 180);
    EXPECT_LT(
        (lut.direction.row(row * w + 0).transpose() - Eigen::Vector3d(-c, 0, std::sin(kPi / 180)))
            .norm(),
        1e-12);
    EXPECT_LT((lut.direction.row(row * w + w / 4).transpose() -
               Eigen::Vector3d(0, c, std::sin(kPi / 180)))
                  .norm(),
              1e-12);
    // A range equal to n puts the point at the beam origin: on a circle of radius n
    // around the lidar axis, at the lidar_to_sensor height.
    for (int m = 0; m < w; m += 37) {
        const Eigen::Vector3d p =
            lut.point(row, m, 0) + lut.direction.row(row * w + m).transpose() * 0.015806;
        EXPECT_NEAR(std::hypot(p.x(), p.y()), 0.015806, 1e-12);
        EXPECT_NEAR(p.z(), 0.03618, 1e-12);
    }
}

TEST(OusterXyzLut, ZeroRangeIsNoPoint) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(meta_path, "same_ports_nonlegacy.2.json");
    const SensorInfo info = load_metadata(meta_path);
    const XyzLut lut = make_xyz_lut(info);
    std::vector<std::uint32_t> range(lut.size(), 0);
    std::mt19937 rng(5);
    std::size_t expected_valid = 0;
    for (auto& r : range) {
        if (rng() % 3 != 0) {
            r = 500 + rng() % 50000;
            ++expected_valid;
        }
    }
    std::vector<Eigen::Vector3f> xyz_f(lut.size());
    std::vector<Eigen::Vector3d> xyz_d(lut.size());
    EXPECT_EQ(project(lut, range.data(), xyz_f.data()), expected_valid);
    EXPECT_EQ(project(lut, range.data(), xyz_d.data()), expected_valid);
    std::vector<Eigen::Vector3d> valid;
    valid.reserve(lut.size());
    EXPECT_EQ(project_valid(lut, range.data(), &valid), expected_valid);
    ASSERT_EQ(valid.size(), expected_valid);
    std::size_t k = 0;
    for (std::size_t i = 0; i < lut.size(); ++i) {
        if (range[i] == 0) {
            EXPECT_TRUE(xyz_d[i].array().isNaN().all());
            EXPECT_TRUE(xyz_f[i].array().isNaN().all());
            continue;
        }
        ASSERT_TRUE(xyz_d[i].allFinite());
        EXPECT_LT((xyz_d[i] - valid[k++]).norm(), 1e-12);
        EXPECT_LT((xyz_f[i].cast<double>() - xyz_d[i]).norm(), 1e-5);
        // Distance from the sensor origin is close to the range (beam origin and the
        // 36 mm lidar height are the only offsets).
        EXPECT_NEAR(xyz_d[i].norm(), range[i] * 1e-3, 0.06);
    }
}

TEST(OusterXyzLut, RejectsInconsistentIntrinsics) {
    EXPECT_THROW(make_xyz_lut(1024, 64, std::vector<double>(63), std::vector<double>(64),
                              Eigen::Matrix4d::Identity(), Eigen::Matrix4d::Identity()),
                 std::invalid_argument);
    EXPECT_THROW(
        make_xyz_lut(0, 1, {0.0}, {0.0}, Eigen::Matrix4d::Identity(), Eigen::Matrix4d::Identity()),
        std::invalid_argument);
}

}  // namespace
}  // namespace lidarfuse::ouster
