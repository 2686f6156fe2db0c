// `lidarfuse calibrate --cloud NAME=FILE ...` through the built binary, on the real rigs of
// ../shared/data/real (SOURCES.md there: recorded by others, references published by
// third parties, each with its own error), and on bad input. Skipped, visibly, where the
// data folder is absent.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <map>

#include "core/common/se3.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/rig_reference.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

// A real rig's folder, or an empty path when the shared data is absent.
std::filesystem::path rig_dir(const std::string& rig) {
    const auto data = test::data_dir();
    if (!data || !std::filesystem::is_directory(*data / "real" / rig)) return {};
    return *data / "real" / rig;
}

struct Calibration {
    int status = -1;
    std::string output;
    std::string root;
    std::map<std::string, io::ExtrinsicsEntry> sensors;
};

Calibration calibrate(const std::string& arguments, const test::TempDir& dir) {
    Calibration c;
    const std::string out = (dir.path() / "extrinsics.yaml").string();
    c.status = test::run_command(test::tool_path() + " calibrate " + arguments + " --out " + out,
                                 &c.output);
    if (!std::filesystem::exists(out)) return c;
    io::ExtrinsicsDocument doc = io::read_extrinsics_document(out);
    c.root = doc.root;
    for (auto& entry : doc.sensors) c.sensors[entry.name] = entry;
    return c;
}

#define LIDARFUSE_REQUIRE_RIG(var, rig)                                                       \
    const std::filesystem::path var = rig_dir(rig);                                           \
    if (var.empty()) {                                                                        \
        GTEST_SKIP() << "real data " << (rig) << " not found (set LIDARFUSE_DATA_DIR to the " \
                     << "shared data folder)";                                                \
    }

// Two Ouster 128-beam units 1.25 m apart, each rolled 20 deg outward. The reference is a
// CAD-level calibration that an independent ICP puts 6.5-6.7 cm / 0.06 deg off: the issue's
// target is 10 cm / 0.1 deg from it. The root is named with --root although listed second.
TEST(CalibrateClouds, RealOusterPairRegistersWithinTheReference) {
    LIDARFUSE_REQUIRE_RIG(dir, "edgar_ouster_pair");
    test::TempDir out("calibrate_edgar");
    const Calibration c = calibrate("--cloud frontleft=" + (dir / "frontleft.pcd").string() +
                                        " --cloud frontright=" + (dir / "frontright.pcd").string() +
                                        " --root frontright",
                                    out);
    ASSERT_EQ(c.status, 0) << c.output;
    EXPECT_EQ(c.root, "frontright");
    ASSERT_TRUE(c.sensors.at("frontleft").registered) << c.output;
    const Eigen::Isometry3d reference = io::read_rig_reference(dir / "T_frontright_frontleft.txt");
    const Eigen::Isometry3d& T = c.sensors.at("frontleft").T_root_sensor;
    EXPECT_LT(core::translation_error_m(T, reference), 0.10) << c.output;
    EXPECT_LT(core::rotation_error_deg(T, reference), 0.1) << c.output;
    EXPECT_TRUE(c.sensors.at("frontright").T_root_sensor.isApprox(Eigen::Isometry3d::Identity()));
}

// A Pandar64 on the roof and two thinned 64-ring units tilted 45 deg to either side (9-10 k
// points against 92 k), 0.7 m from it. Both side units must be registered against the top
// one within the 0.3 deg and 3 cm of the references (another algorithm's result
// on this scene, 0.5-0.6 cm / 0.01-0.04 deg from an independent ICP). The right -> top pair
// finds no candidate of its own; the right unit is placed through the left one and the
// loop closure refines right -> top from there (bench/BENCHMARK.md).
TEST(CalibrateClouds, RealRoadRigRegistersBothTiltedSideUnits) {
    LIDARFUSE_REQUIRE_RIG(dir, "opencalib_road_rig");
    test::TempDir out("calibrate_opencalib");
    std::string arguments;
    for (const char* name : {"top", "left", "right"}) {
        arguments +=
            std::string(" --cloud ") + name + "=" + (dir / (std::string(name) + ".pcd")).string();
    }
    const Calibration c = calibrate(arguments, out);
    ASSERT_EQ(c.status, 0) << c.output;
    EXPECT_EQ(c.root, "top");
    for (const char* name : {"left", "right"}) {
        ASSERT_TRUE(c.sensors.at(name).registered) << name << "\n" << c.output;
        const Eigen::Isometry3d reference =
            io::read_rig_reference(dir / ("T_top_" + std::string(name) + ".txt"));
        const Eigen::Isometry3d& T = c.sensors.at(name).T_root_sensor;
        EXPECT_LT(core::translation_error_m(T, reference), 0.03) << name << "\n" << c.output;
        EXPECT_LT(core::rotation_error_deg(T, reference), 0.3) << name << "\n" << c.output;
    }
}

TEST(CalibrateClouds, BadCloudArgumentsFailWithTheirName) {
    test::TempDir dir("calibrate_clouds_bad");
    const std::string d = dir.path().string();
    {
        std::ofstream bad(d + "/broken.pcd");
        bad << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
               "WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n4 5 6\n";
    }
    struct Case {
        std::string arguments;
        std::string expected;
    };
    const Case cases[] = {
        {"--cloud a=" + d + "/absent.pcd --cloud b=" + d + "/absent.pcd", "absent.pcd"},
        {"--cloud a=" + d + "/broken.pcd --cloud b=" + d + "/broken.pcd", "broken.pcd"},
        {"--cloud a" + d + "/broken.pcd --cloud b=" + d + "/broken.pcd", "expected NAME=FILE"},
        {"--cloud a=" + d + "/broken.pcd", "at least two"},
        {"--cloud a=" + d + "/x.pcd --cloud a=" + d + "/y.pcd", "given twice"},
        {"--cloud a=" + d + "/x.pcd --cloud b=" + d + "/y.pcd --root c", "--root c"},
        {d + "/capture.pcap --cloud a=" + d + "/x.pcd --cloud b=" + d + "/y.pcd",
         "cannot be combined"},
    };
    for (const Case& c : cases) {
        const Calibration result = calibrate(c.arguments, dir);
        EXPECT_EQ(result.status, 1) << c.arguments << "\n" << result.output;
        EXPECT_NE(result.output.find(c.expected), std::string::npos) << c.arguments << "\n"
                                                                     << result.output;
        EXPECT_FALSE(std::filesystem::exists(d + "/extrinsics.yaml")) << c.arguments;
    }
}

}  // namespace
}  // namespace lidarfuse
