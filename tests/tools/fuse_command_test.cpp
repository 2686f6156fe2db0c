// `lidarfuse sim` -> `lidarfuse fuse` -> `lidarfuse eval`, through the built binaries: the
// production ingest, synchroniser and FusionEngine on a simulated capture with ground truth.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "drivers/io/pose_csv.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

using ::testing::HasSubstr;

double figure(const std::string& output, const std::string& name) {
    return test::figure(output, name).value_or(-1);
}

TEST(FuseCommand, SimulatedStationIsFusedAgainstGroundTruth) {
    test::TempDir dir("fuse");
    const std::string d = dir.path().string();
    const std::string tool = test::tool_path();
    std::string out;
    ASSERT_EQ(
        test::run_command(
            tool + " sim --scenario curve --sensors 2 --seconds 0.5 --out " + d + "/sim", &out),
        0)
        << out;
    out.clear();
    ASSERT_EQ(test::run_command(tool + " fuse " + d + "/sim/capture.pcap --config " + d +
                                    "/sim/station.yaml --out " + d + "/fuse --save-cloud 3",
                                &out),
              0)
        << out;
    EXPECT_EQ(figure(out, "fuse_frames"), 10) << out;
    EXPECT_EQ(figure(out, "fuse_frames_partial"), 0) << out;

    // The root has a pose in every frame; lidar1 wherever the initial registration
    // succeeded (it is retried every 10 frames when it fails).
    const auto poses = io::read_pose_csv(dir.path() / "fuse/poses.csv");
    std::size_t root_rows = 0;
    for (const auto& p : poses) root_rows += p.sensor == "lidar0";
    EXPECT_EQ(root_rows, 10u);
    std::ifstream timing(dir.path() / "fuse/timing.csv");
    std::string line;
    int rows = -1;
    while (std::getline(timing, line)) ++rows;
    EXPECT_EQ(rows, 10);
    std::ifstream ply(dir.path() / "fuse/fused_3.ply", std::ios::binary);
    std::string header;
    std::getline(ply, header);
    EXPECT_EQ(header, "ply");

    out.clear();
    ASSERT_EQ(test::run_command(tool + " eval --gt " + d + "/sim/ground_truth.csv --poses " + d +
                                    "/fuse/poses.csv",
                                &out),
              0)
        << out;
    EXPECT_THAT(out, HasSubstr("eval_lidar0_matched_frames 10 frames"));
    // Every pose written is tracked against ground truth (strict: no fitted alignment).
    const double trans = figure(out, "eval_mean_strict_rmse_trans");
    const double rot = figure(out, "eval_mean_strict_rmse_rot");
    std::printf("fuse_command_test_strict_rmse %.4f m %.4f deg\n", trans, rot);
    EXPECT_GE(trans, 0.0);
    EXPECT_LT(trans, 0.05);
    EXPECT_LT(rot, 0.2);
}

// fuse reads the config's registration and dynamics sections as lidarfused does; the
// options override them, and a bad key in them is refused with its path.
TEST(FuseCommand, UsesTheConfigsRegistrationSectionUnlessOverridden) {
    test::TempDir dir("fusecfg");
    const std::string d = dir.path().string();
    const std::string tool = test::tool_path();
    std::string out;
    ASSERT_EQ(test::run_command(tool + " sim --scenario curve --sensors 2 --seconds 0.2 --out " + d,
                                &out),
              0)
        << out;
    const auto with_sections = [&](const std::string& name, const std::string& sections) {
        std::ifstream in(dir.path() / "station.yaml");
        std::ofstream config(dir.path() / name);
        config << in.rdbuf() << sections;
        return d + "/" + name;
    };
    const std::string tuned = with_sections(
        "tuned.yaml",
        "registration:\n  voxel_size_m: 3.0\n  window_frames: 7\ndynamics:\n  enabled: false\n");
    const std::string run =
        tool + " fuse " + d + "/capture.pcap --out " + d + "/out --max-frames 2 --config ";
    out.clear();
    ASSERT_EQ(test::run_command(run + tuned, &out), 0) << out;
    EXPECT_EQ(figure(out, "fuse_voxel_size"), 3.0) << out;
    EXPECT_EQ(figure(out, "fuse_window"), 7.0);
    EXPECT_EQ(figure(out, "fuse_remove_dynamic"), 0.0);
    EXPECT_EQ(figure(out, "fuse_deskew"), 1.0);
    out.clear();
    ASSERT_EQ(test::run_command(run + tuned + " --voxel-size 1 --window 4 --no-deskew", &out), 0)
        << out;
    EXPECT_EQ(figure(out, "fuse_voxel_size"), 1.0) << out;
    EXPECT_EQ(figure(out, "fuse_window"), 4.0);
    EXPECT_EQ(figure(out, "fuse_deskew"), 0.0);
    out.clear();
    ASSERT_EQ(test::run_command(run + d + "/station.yaml", &out), 0) << out;
    EXPECT_EQ(figure(out, "fuse_voxel_size"), 1.0) << out;  // FusionParams' defaults
    EXPECT_EQ(figure(out, "fuse_window"), 5.0);
    EXPECT_EQ(figure(out, "fuse_remove_dynamic"), 1.0);
    out.clear();
    const std::string bad =
        with_sections("bad.yaml", "registration:\n  voxel_size_m: -1\n  voxel_sise_m: 2\n");
    EXPECT_NE(test::run_command(run + bad, &out), 0);
    EXPECT_THAT(out, HasSubstr("bad.yaml"));
    EXPECT_THAT(out, HasSubstr("registration.voxel_size_m"));
    EXPECT_THAT(out, HasSubstr("registration.voxel_sise_m"));
}

TEST(FuseCommand, BadInputFailsWithTheFileNamed) {
    test::TempDir dir("fusebad");
    std::string out;
    EXPECT_NE(test::run_command(test::tool_path() + " fuse /nonexistent.pcap --config " +
                                    (dir.path() / "missing.yaml").string() + " --out " +
                                    dir.path().string(),
                                &out),
              0);
    EXPECT_THAT(out, HasSubstr("missing.yaml"));
    out.clear();
    EXPECT_NE(test::run_command(test::tool_path() + " fuse", &out), 0);
    EXPECT_THAT(out, HasSubstr("CAPTURE.pcap"));
}

}  // namespace
}  // namespace lidarfuse
