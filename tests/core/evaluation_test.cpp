#include "core/evaluation/evaluation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace lidarfuse::core {
namespace {

Eigen::Isometry3d pose(double x, double y, double z, double yaw_deg, double roll_deg = 0) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(roll_deg * M_PI / 180, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(x, y, z);
    return T;
}

// A 4-sensor station with swaying poles, in the world frame, 100 frames at 20 Hz.
Trajectories world_truth() {
    Trajectories gt;
    const Eigen::Isometry3d nominal[4] = {pose(0, 0, 6, 90, 17), pose(20, 25, 6, -90, 17),
                                          pose(40, 0, 6, 90, 17), pose(60, 25, 6, -90, 17)};
    for (int s = 0; s < 4; ++s) {
        for (int f = 0; f < 100; ++f) {
            const double t = f * 0.05;
            const Eigen::Isometry3d sway = pose(0.2 * std::sin(t + s), 0.1 * std::cos(2 * t), 0,
                                                1.5 * std::sin(t * 0.7 + s), 0);
            gt["lidar" + std::to_string(s)].push_back(
                {f, 1'000'000'000 + f * 50'000'000LL, nominal[s] * sway});
        }
    }
    return gt;
}

// The estimate a perfect fusion would give: everything relative to lidar0 at frame 0.
Trajectories perfect_estimate(const Trajectories& gt) {
    const Eigen::Isometry3d root0_inv = gt.at("lidar0").front().pose.inverse();
    Trajectories est;
    for (const auto& [name, samples] : gt) {
        for (const auto& s : samples) est[name].push_back({s.frame, s.t_ns, root0_inv * s.pose});
    }
    return est;
}

TEST(Evaluation, PerfectEstimateHasZeroErrorBothWays) {
    const auto gt = world_truth();
    const auto result = evaluate_trajectories(gt, perfect_estimate(gt));
    ASSERT_TRUE(result.ok) << result.error;
    EXPECT_EQ(result.root_sensor, "lidar0");
    ASSERT_EQ(result.sensors.size(), 4u);
    for (const auto& s : result.sensors) {
        EXPECT_EQ(s.matched, 100u);
        EXPECT_LT(s.rmse_trans_m, 1e-9);
        EXPECT_LT(s.rmse_rot_deg, 1e-5);
        EXPECT_LT(s.strict_rmse_trans_m, 1e-9);
        EXPECT_LT(s.strict_rmse_rot_deg, 1e-5);
    }
}

// A constant error on one sensor shows up in that sensor's RMSE with its size.
TEST(Evaluation, KnownErrorOnOneSensorIsMeasured) {
    const auto gt = world_truth();
    auto est = perfect_estimate(gt);
    for (auto& s : est["lidar2"]) s.pose = s.pose * pose(0.03, 0.04, 0, 0.5);
    EvaluationParams params;
    params.root_sensor = "lidar0";
    const auto result = evaluate_trajectories(gt, est, params);
    ASSERT_TRUE(result.ok);
    const auto& l2 = result.sensors[2];
    ASSERT_EQ(l2.sensor, "lidar2");
    EXPECT_NEAR(l2.strict_rmse_trans_m, 0.05, 1e-9);
    EXPECT_NEAR(l2.strict_rmse_rot_deg, 0.5, 1e-6);
    EXPECT_NEAR(result.mean_strict_rmse_trans_m, 0.05 / 4, 1e-9);
    // The fitted alignment spreads part of the error over the others, never removes it.
    EXPECT_GT(l2.rmse_trans_m, 0.02);
    EXPECT_GT(l2.rmse_rot_deg, 0.2);
}

// A rigid transform of the whole estimate is its frame (world.frame road or geo), not an
// error: removed by the fitted T_coord and by the strict metric's re-expression relative to
// the root's first pose. A jump of the whole estimate half-way through is an error, which
// the strict metric counts in full (the fitted T_coord spreads it).
TEST(Evaluation, WholeEstimateInAnotherFrameIsNoErrorButAJumpIs) {
    const auto gt = world_truth();
    auto est = perfect_estimate(gt);
    const Eigen::Isometry3d offset = pose(0.5, -0.2, 6.1, 3.0, 17.0);
    for (auto& [name, samples] : est) {
        for (auto& s : samples) s.pose = offset * s.pose;
    }
    EvaluationParams params;
    params.root_sensor = "lidar0";
    auto result = evaluate_trajectories(gt, est, params);
    ASSERT_TRUE(result.ok);
    EXPECT_LT(result.mean_rmse_trans_m, 1e-6);
    EXPECT_LT(result.mean_rmse_rot_deg, 1e-4);
    EXPECT_LT(result.mean_strict_rmse_trans_m, 1e-6);
    EXPECT_LT(result.mean_strict_rmse_rot_deg, 1e-4);
    // The root found without being named: the one nearest the frame's z axis.
    result = evaluate_trajectories(gt, est, {});
    EXPECT_EQ(result.root_sensor, "lidar0");

    const Eigen::Isometry3d jump = pose(0.3, 0, 0, 1.0);
    for (auto& [name, samples] : est) {
        for (auto& s : samples) {
            if (s.frame >= 50) s.pose = jump * s.pose;
        }
    }
    result = evaluate_trajectories(gt, est, params);
    ASSERT_TRUE(result.ok);
    EXPECT_GT(result.mean_strict_rmse_trans_m, 0.2);
    EXPECT_NEAR(result.mean_strict_rmse_rot_deg, std::sqrt(0.5), 1e-3);
}

// world = road: each sensor's height and up direction in the estimate's own frame.
TEST(Evaluation, RoadWorldFiguresAreHeightAndUpDirection) {
    const auto gt = world_truth();
    Trajectories est;
    // A road-aligned estimate: the truth rotated about z and shifted horizontally, with
    // lidar2 2 cm too high.
    const Eigen::Isometry3d yaw_shift = pose(-3, 7, 0, 40);
    for (const auto& [name, samples] : gt) {
        for (const auto& s : samples) {
            Eigen::Isometry3d p = yaw_shift * s.pose;
            if (name == "lidar2") p.translation().z() += 0.02;
            est[name].push_back({s.frame, s.t_ns, p});
        }
    }
    EvaluationParams params;
    params.root_sensor = "lidar0";
    params.world = EvaluationParams::World::kRoad;
    const auto result = evaluate_trajectories(gt, est, params);
    ASSERT_TRUE(result.ok);
    for (const auto& s : result.sensors) {
        EXPECT_NEAR(s.world_rmse_trans_m, s.sensor == "lidar2" ? 0.02 : 0.0, 1e-9) << s.sensor;
        EXPECT_LT(s.world_rmse_rot_deg, 1e-6) << s.sensor;
    }
}

TEST(Evaluation, DriftShowsInTheLastTenth) {
    const auto gt = world_truth();
    auto est = perfect_estimate(gt);
    auto& l1 = est["lidar1"];
    for (std::size_t i = 0; i < l1.size(); ++i) l1[i].pose.translation().z() += 0.001 * i;
    EvaluationParams params;
    params.root_sensor = "lidar0";
    const auto result = evaluate_trajectories(gt, est, params);
    const auto& e = result.sensors[1];
    EXPECT_GT(e.last_tenth_rmse_trans_m, 5 * e.first_tenth_rmse_trans_m);
}

TEST(Evaluation, MatchesByTimestampAndReportsMissingFrames) {
    const auto gt = world_truth();
    auto est = perfect_estimate(gt);
    for (auto& [name, samples] : est) {
        samples.erase(samples.begin() + 10, samples.begin() + 20);  // 10 frames not fused
        for (auto& s : samples) {
            s.frame += 1000;      // another numbering
            s.t_ns += 3'000'000;  // 3 ms off: still the same frame
        }
    }
    const auto result = evaluate_trajectories(gt, est);
    ASSERT_TRUE(result.ok);
    for (const auto& s : result.sensors) {
        EXPECT_EQ(s.matched, 90u);
        EXPECT_EQ(s.missing, 10u);
        EXPECT_LT(s.strict_rmse_trans_m, 1e-9);
    }
}

TEST(Evaluation, NoOverlapIsAnErrorNotANumber) {
    Trajectories gt = world_truth(), est;
    est["other"].push_back({0, 0, Eigen::Isometry3d::Identity()});
    const auto result = evaluate_trajectories(gt, est);
    EXPECT_FALSE(result.ok);
    EXPECT_FALSE(result.error.empty());
}

// Two sensors (positions along one line, plus sway): the rotation about that line is not
// observable from positions, so no fitted T_coord is used; the aligned figures then equal
// the strict ones instead of absorbing an arbitrary rotation.
TEST(Evaluation, CollinearPositionsFallBackToTheRootPose) {
    auto gt = world_truth();
    gt.erase("lidar2");
    gt.erase("lidar3");
    auto est = perfect_estimate(gt);
    for (auto& s : est["lidar1"]) s.pose.translation().z() += 0.01;
    // The estimate in a road or geo frame (its root not at the identity) as well: the
    // fallback maps root onto root, not the truth's root onto the estimate's frame.
    auto est_in_road = est;
    const Eigen::Isometry3d T_road_root0 = pose(3.0, -2.0, 6.0, 40.0, 17.0);
    for (auto& [name, samples] : est_in_road) {
        for (auto& s : samples) s.pose = T_road_root0 * s.pose;
    }
    for (const auto* estimate : {&est, &est_in_road}) {
        const auto result = evaluate_trajectories(gt, *estimate);
        ASSERT_TRUE(result.ok);
        EXPECT_EQ(result.alignment, "root");
        EXPECT_NEAR(result.mean_rmse_trans_m, 0.005, 1e-6);
        for (const auto& s : result.sensors) {
            EXPECT_NEAR(s.rmse_trans_m, s.strict_rmse_trans_m, 1e-9);
            EXPECT_NEAR(s.rmse_rot_deg, s.strict_rmse_rot_deg, 1e-9);
        }
    }
    EXPECT_EQ(evaluate_trajectories(world_truth(), perfect_estimate(world_truth())).alignment,
              "svd");
    // One swaying sensor alone: its sway spans a small plane, which must not count.
    gt.erase("lidar1");
    EXPECT_EQ(evaluate_trajectories(gt, perfect_estimate(gt)).alignment, "root");
}

}  // namespace
}  // namespace lidarfuse::core
