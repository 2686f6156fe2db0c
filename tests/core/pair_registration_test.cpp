#include "core/registration/pair_registration.hpp"

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "tests/core/street_features.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

using testing::street_features;

// Sensors 0 and 2 of the street: 100 degrees of relative yaw, no initial guess.
TEST(PairRegistration, RegistersTwoSensorsAndIsDeterministic) {
    const SensorFeatures target = street_features(0);
    const SensorFeatures source = street_features(2);
    ASSERT_EQ(target.status, SensorFeatureStatus::kOk);
    ASSERT_EQ(source.status, SensorFeatureStatus::kOk);
    const auto poses = testing::street_sensor_poses();
    const Eigen::Isometry3d truth = poses[0].inverse() * poses[2];
    const PairResult r = register_pair(source, target, 2, 0);
    ASSERT_EQ(r.status, PairStatus::kOk) << to_string(r.status);
    EXPECT_EQ(r.source, 2);
    EXPECT_EQ(r.target, 0);
    EXPECT_LT(translation_error_m(r.chosen.T_target_source, truth), 0.03);
    EXPECT_LT(rotation_error_deg(r.chosen.T_target_source, truth), 0.1);
    EXPECT_GE(r.candidates, 1);
    EXPECT_GE(r.chosen.candidate, 0);
    EXPECT_GT(r.num_matches, r.chosen.ransac_inliers);
    EXPECT_GT(r.chosen.overlap_share, 0.3);
    EXPECT_LT(r.chosen.p2p_error_m, 0.5);
    EXPECT_GT(r.chosen.min_hessian_eigenvalue, 0.0);
    EXPECT_TRUE(r.chosen.information.isApprox(r.chosen.information.transpose()));
    // Every candidate tried is recorded with the check that dropped it; the kept ones are
    // the pair's candidates, and the chosen one is among them with its figures.
    int kept = 0;
    bool chosen_recorded = false;
    for (const CandidateRecord& c : r.tried) {
        if (c.outcome != CandidateOutcome::kKept) continue;
        ++kept;
        EXPECT_GE(c.free_space_share, 0.0);
        EXPECT_LE(c.free_space_share, 0.08);
        if (c.candidate == r.chosen.candidate) {
            chosen_recorded = true;
            EXPECT_DOUBLE_EQ(c.p2p_error_m, r.chosen.p2p_error_m);
            EXPECT_DOUBLE_EQ(c.overlap_share, r.chosen.overlap_share);
            EXPECT_TRUE(c.T_refined.isApprox(r.chosen.T_target_source, 0.0));
        }
    }
    EXPECT_EQ(kept, r.candidates);
    EXPECT_TRUE(chosen_recorded);

    const PairResult again = register_pair(source, target, 2, 0);
    EXPECT_TRUE(again.chosen.T_target_source.isApprox(r.chosen.T_target_source, 0.0));
    EXPECT_EQ(again.num_matches, r.num_matches);
    EXPECT_EQ(again.chosen.candidate, r.chosen.candidate);
}

TEST(PairRegistration, FailedSensorIsNotMatched) {
    const SensorFeatures target = street_features(0);
    const SensorFeatures empty = compute_sensor_features(PointCloud{}, {});
    const PairResult r = register_pair(empty, target, 1, 0);
    EXPECT_EQ(r.status, PairStatus::kSensorFailed);
    EXPECT_TRUE(r.chosen.T_target_source.isApprox(Eigen::Isometry3d::Identity()));
}

}  // namespace
}  // namespace lidarfuse::core
