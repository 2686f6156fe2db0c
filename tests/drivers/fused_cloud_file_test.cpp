// Fused clouds as files: PLY and PCD read back by the project's own readers (which follow
// the formats' specifications, tested against files from other tools in cloud_file_test)
// with every point's position and intensity, and the sensor and dynamic bytes where the
// header says they are.
#include "drivers/io/fused_cloud_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "drivers/io/cloud_file.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::io {
namespace {

core::FusedCloud three_points() {
    core::FusedCloud c;
    c.points = {{1.5f, -2.25f, 3.0f}, {10.0f, 0.0f, -0.5f}, {-7.0f, 4.0f, 0.25f}};
    c.intensity = {0.0f, 120.5f, 3.0f};
    c.sensor = {0, 3, 7};
    c.dynamic = {0, 1, 0};
    return c;
}

// The last 3 x 18 bytes of the file: the points' records.
std::string records_of(const std::string& file_text) {
    return file_text.substr(file_text.size() - 54);
}

TEST(FusedCloudFile, PcdAndPlyReadBackWithEveryField) {
    test::TempDir dir("fused-cloud");
    const auto cloud = three_points();
    write_fused_cloud_pcd(dir.path() / "c.pcd", cloud);
    write_fused_cloud_ply(dir.path() / "c.ply", cloud);
    for (const char* name : {"c.pcd", "c.ply"}) {
        const auto read = read_cloud_file(dir.path() / name);
        ASSERT_EQ(read.cloud.points.size(), 3u) << name;
        ASSERT_EQ(read.intensity.size(), 3u) << name;
        for (std::size_t i = 0; i < 3; ++i) {
            EXPECT_EQ(read.cloud.points[i], cloud.points[i].cast<double>()) << name << " " << i;
            EXPECT_EQ(read.intensity[i], cloud.intensity[i]) << name << " " << i;
        }
        const std::string records = records_of(test::file_text(dir.path() / name));
        for (std::size_t i = 0; i < 3; ++i) {
            EXPECT_EQ(static_cast<std::uint8_t>(records[i * 18 + 16]), cloud.sensor[i]) << name;
            EXPECT_EQ(static_cast<std::uint8_t>(records[i * 18 + 17]), cloud.dynamic[i]) << name;
        }
    }
    EXPECT_THAT(test::file_text(dir.path() / "c.pcd"),
                ::testing::HasSubstr("FIELDS x y z intensity sensor_id dynamic\nSIZE 4 4 4 4 1 1\n"
                                     "TYPE F F F F U U\n"));
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "c.pcd.tmp"));
}

TEST(FusedCloudFile, MismatchedAttributesAreRefusedByName) {
    test::TempDir dir("fused-cloud");
    auto cloud = three_points();
    cloud.dynamic.pop_back();
    EXPECT_THROW(write_fused_cloud_pcd(dir.path() / "c.pcd", cloud), std::runtime_error);
    try {
        write_fused_cloud_ply(dir.path() / "c.ply", cloud);
        FAIL() << "no error";
    } catch (const std::runtime_error& error) {
        EXPECT_THAT(error.what(),
                    ::testing::HasSubstr("c.ply: fused cloud attributes do not match"));
    }
}

}  // namespace
}  // namespace lidarfuse::io
