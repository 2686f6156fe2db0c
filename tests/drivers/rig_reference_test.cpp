// A rig's reference transform (drivers/io/rig_reference.hpp): the shared files as golden
// values, and files that are not a 4 x 4 transform.
#include "drivers/io/rig_reference.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "tests/support/test_data.hpp"

namespace lidarfuse::io {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

// T_top_left.txt's first row and translation, as the file holds them (SOURCES.md).
TEST(RigReference, ReadsTheSharedOpenCalibReference) {
    const auto data = test::data_dir();
    const auto file =
        data ? *data / "real" / "opencalib_road_rig" / "T_top_left.txt" : std::filesystem::path();
    if (!data || !std::filesystem::exists(file))
        GTEST_SKIP() << "real data not found (set LIDARFUSE_DATA_DIR)";
    const Eigen::Isometry3d T = read_rig_reference(file);
    EXPECT_DOUBLE_EQ(T(0, 0), -0.023526595);
    EXPECT_DOUBLE_EQ(T(0, 1), -0.995000153);
    EXPECT_DOUBLE_EQ(T(2, 2), 0.703654937);
    EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(-0.004387390, 0.587301000, -0.397629000)));
}

std::string error_reading(const std::string& text) {
    test::TempDir dir("rigref");
    const auto file = dir.path() / "T_a_b.txt";
    std::ofstream(file) << text;
    try {
        read_rig_reference(file);
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "(no error)";
}

TEST(RigReference, RefusesWhatIsNotATransformNamingTheFile) {
    EXPECT_THAT(error_reading("1 0 0 0\n0 1 0 0\n0 0 1 0\n"),
                HasSubstr("T_a_b.txt: expected 16 numbers"));
    EXPECT_THAT(error_reading("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 x 1\n"),
                HasSubstr("expected 16 numbers"));
    EXPECT_THAT(error_reading("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n"),
                HasSubstr("last row must be 0 0 0 1"));
    EXPECT_EQ(error_reading("1 0 0 5\n0 1 0 6\n0 0 1 7\n0 0 0 1\n"), "(no error)");
    EXPECT_THAT(error_reading(""), StartsWith("/"));
    try {
        read_rig_reference("/nonexistent/T_x_y.txt");
        ADD_FAILURE() << "no error for a missing file";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(std::string(e.what()), HasSubstr("T_x_y.txt: cannot open"));
    }
}

}  // namespace
}  // namespace lidarfuse::io
