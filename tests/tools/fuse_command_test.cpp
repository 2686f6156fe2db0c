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
    ASSERT_EQ(test::run_command(tool + " sim --scenario curve --sensors 2 --seconds 0.5 --out " + d + "/sim", &out), 0)
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

TEST(FuseCommand, BadInputFailsWithTheFileNamed) {
    test::TempDir dir("fusebad");
    std::string out;
    EXPECT_NE(test::run_command(test::tool_path() + " fuse /nonexistent.pcap --config " +
                                    (dir.path() / "missing.yaml").string() + " --out " + dir.path().string(),
                                &out),
              0);
    EXPECT_THAT(out, HasSubstr("missing.yaml"));
    out.clear();
    EXPECT_NE(test::run_command(test::tool_path() + " fuse", &out), 0);
    EXPECT_THAT(out, HasSubstr("CAPTURE.pcap"));
}

}  // namespace
}  // namespace lidarfuse
