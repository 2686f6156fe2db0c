// Runs the built `lidarfuse eval` on CSV files written here.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "drivers/io/fused_cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

using ::testing::HasSubstr;

class EvalCommand : public ::testing::Test {
protected:
    void SetUp() override {
        std::vector<io::PoseRecord> gt, est;
        const Eigen::Isometry3d root0 = make(0.1 * std::sin(0.0), 0, 6, 0.1 * std::sin(0.0));
        for (int f = 0; f < 40; ++f) {
            for (int s = 0; s < 3; ++s) {
                const double sway = 0.1 * std::sin(0.2 * f + s);
                io::PoseRecord r{f, "lidar" + std::to_string(s), 1000 + f * 50'000'000LL,
                                 make(s * 25.0 + sway, 10.0 * s, 6, 30.0 * s + sway)};
                gt.push_back(r);
                r.pose = root0.inverse() * r.pose;
                if (s == 1) r.pose.translation().x() += 0.02;  // 2 cm error on lidar1
                est.push_back(r);
            }
        }
        io::write_pose_csv(dir_.path() / "ground_truth.csv", gt);
        io::write_pose_csv(dir_.path() / "poses.csv", est);
    }
    static Eigen::Isometry3d make(double x, double y, double z, double yaw_deg) {
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.linear() =
            Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        T.translation() = Eigen::Vector3d(x, y, z);
        return T;
    }
    test::TempDir dir_{"eval"};
};

TEST_F(EvalCommand, PrintsPerSensorAndMeanFigures) {
    std::string out;
    const auto d = dir_.path().string();
    ASSERT_EQ(
        test::run_command(test::tool_path() + " eval --gt " + d + "/ground_truth.csv --poses " + d +
                              "/poses.csv --plot " + d + "/plots",
                          &out),
        0)
        << out;
    EXPECT_THAT(out, HasSubstr("eval_root_sensor lidar0 name"));
    EXPECT_THAT(out, HasSubstr("eval_lidar1_strict_rmse_trans 0.020000 m"));
    EXPECT_THAT(out, HasSubstr("eval_lidar0_strict_rmse_trans 0.000000 m"));
    EXPECT_THAT(out, HasSubstr("eval_lidar2_matched_frames 40 frames"));
    EXPECT_THAT(out, HasSubstr("eval_mean_strict_rmse_trans 0.006667 m"));
    for (const char* plot : {"translation_error.svg", "rotation_error.svg",
                             "strict_translation_error.svg", "strict_rotation_error.svg"}) {
        std::ifstream svg(dir_.path() / "plots" / plot);
        std::string text((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
        EXPECT_THAT(text, HasSubstr("<polyline")) << plot;
        EXPECT_THAT(text, HasSubstr("lidar2")) << plot;
    }
}

// A fused frame: sensor 0's points on the left half, sensor 1's on the right, a dynamic
// blob in the middle; the top view colours each cell by its majority.
TEST_F(EvalCommand, DrawsATopViewOfAFusedCloudColouredBySensor) {
    core::FusedCloud cloud;
    for (int i = 0; i < 2000; ++i) {
        const float x = -20.0f + 40.0f * static_cast<float>(i % 100) / 100.0f;
        const float y = -10.0f + 20.0f * static_cast<float>(i / 100) / 20.0f;
        const bool blob = std::abs(x) < 2 && std::abs(y) < 2;
        cloud.points.emplace_back(x, y, 0.0f);
        cloud.intensity.push_back(1.0f);
        cloud.sensor.push_back(x < 0 ? 0 : 1);
        cloud.dynamic.push_back(blob ? 1 : 0);
    }
    const auto d = dir_.path().string();
    io::write_fused_cloud_ply(dir_.path() / "fused_7.ply", cloud);
    std::string out;
    ASSERT_EQ(
        test::run_command(test::tool_path() + " eval --gt " + d + "/ground_truth.csv --poses " + d +
                              "/poses.csv --plot " + d + "/plots --cloud " + d + "/fused_7.ply",
                          &out),
        0)
        << out;
    EXPECT_THAT(out, HasSubstr("eval_top_view_points 2000 points"));
    std::ifstream svg(dir_.path() / "plots" / "top_view.svg");
    const std::string text((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
    EXPECT_THAT(text, HasSubstr("fill=\"#1f77b4\"/>"));  // sensor 0
    EXPECT_THAT(text, HasSubstr("fill=\"#d62728\"/>"));  // sensor 1
    EXPECT_THAT(text, HasSubstr("fill=\"#444444\"/>"));  // dynamic
    EXPECT_THAT(text, HasSubstr("sensor 1</text>"));
    EXPECT_THAT(text, HasSubstr("fused_7.ply"));

    // --cloud alone, and a file that is not a fused cloud, fail with the reason.
    out.clear();
    EXPECT_NE(
        test::run_command(test::tool_path() + " eval --gt " + d + "/ground_truth.csv --poses " + d +
                              "/poses.csv --cloud " + d + "/fused_7.ply",
                          &out),
        0);
    EXPECT_THAT(out, HasSubstr("--cloud needs --plot"));
    std::ofstream(dir_.path() / "bad.ply") << "ply\nformat ascii 1.0\nend_header\n";
    out.clear();
    EXPECT_EQ(
        test::run_command(test::tool_path() + " eval --gt " + d + "/ground_truth.csv --poses " + d +
                              "/poses.csv --plot " + d + "/plots --cloud " + d + "/bad.ply",
                          &out),
        1);
    EXPECT_THAT(out, HasSubstr("bad.ply: unsupported \"format ascii 1.0\""));
}

TEST_F(EvalCommand, MissingFileAndBadArgumentsFailClearly) {
    std::string out;
    EXPECT_EQ(test::run_command(test::tool_path() + " eval --gt /nonexistent.csv --poses " +
                                    (dir_.path() / "poses.csv").string(),
                                &out),
              1);
    EXPECT_THAT(out, HasSubstr("/nonexistent.csv: cannot open"));
    out.clear();
    EXPECT_NE(test::run_command(test::tool_path() + " eval --poses", &out), 0);
    EXPECT_THAT(out, HasSubstr("--poses expects a value"));
}

}  // namespace
}  // namespace lidarfuse
