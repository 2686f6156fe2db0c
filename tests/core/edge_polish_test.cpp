#include "core/initial/edge_polish.hpp"

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "tests/core/street_features.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

using testing::street_features;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Sensors 0 and 2 of the synthetic street, and a pair result for them that register_pair
// could have left: the truth moved by `nudge` (rotation rad, then translation m).
struct StreetPair {
    std::vector<SensorFeatures> features;
    Eigen::Isometry3d truth;
    std::vector<PairResult> pairs;
};

StreetPair street_pair(const Vector6d& nudge) {
    StreetPair s;
    s.features.push_back(street_features(0));
    s.features.push_back(SensorFeatures{});
    s.features.push_back(street_features(2));
    const auto poses = testing::street_sensor_poses();
    s.truth = poses[0].inverse() * poses[2];
    PairResult pair;
    pair.source = 2;
    pair.target = 0;
    pair.status = PairStatus::kOk;
    pair.chosen.T_target_source = s.truth * se3_exp(nudge);
    pair.chosen.information = Matrix6d::Identity();
    s.pairs.push_back(pair);
    return s;
}

TEST(EdgePolish, MovesAChosenPairTowardsTheTruth) {
    Vector6d nudge;
    nudge << 0.0, 0.0, 0.3 * kDeg, 0.04, -0.03, 0.0;
    StreetPair s = street_pair(nudge);
    ASSERT_FALSE(s.features[0].polish.empty());
    ASSERT_FALSE(s.features[2].polish.empty());
    const double before_m = translation_error_m(s.pairs[0].chosen.T_target_source, s.truth);
    const double before_deg = rotation_error_deg(s.pairs[0].chosen.T_target_source, s.truth);

    const EdgePolishSummary summary =
        polish_edges(s.features, {true}, EdgePolishParams{}, &s.pairs);
    EXPECT_EQ(summary.polished, 1u);
    EXPECT_EQ(summary.kept, 0u);
    const PairResult& p = s.pairs[0];
    EXPECT_TRUE(p.polished);
    EXPECT_LT(translation_error_m(p.chosen.T_target_source, s.truth), 0.3 * before_m);
    EXPECT_LT(rotation_error_deg(p.chosen.T_target_source, s.truth), 0.3 * before_deg);
    // The edge now carries the polish run's information and figures.
    EXPECT_FALSE(p.chosen.information.isApprox(Matrix6d::Identity()));
    EXPECT_TRUE(p.chosen.information.isApprox(p.chosen.information.transpose()));
    EXPECT_GT(p.chosen.min_hessian_eigenvalue, 0.0);
    EXPECT_GT(p.chosen.gicp_inliers, 0u);
    EXPECT_GT(p.chosen.p2p_inliers, 0u);
    EXPECT_GT(p.chosen.overlap_share, 0.3);
}

// A pair farther off than the polish limits keeps its transform: the polish refines a
// decision, it never makes a new one.
TEST(EdgePolish, KeepsAPairWhoseRunMovesBeyondTheLimits) {
    Vector6d nudge;
    nudge << 0.0, 0.0, 0.3 * kDeg, 0.04, -0.03, 0.0;
    StreetPair s = street_pair(nudge);
    const Eigen::Isometry3d chosen = s.pairs[0].chosen.T_target_source;
    EdgePolishParams params;
    params.max_shift_m = 0.005;  // the run moves ~5 cm
    const EdgePolishSummary summary = polish_edges(s.features, {true}, params, &s.pairs);
    EXPECT_EQ(summary.polished, 0u);
    EXPECT_EQ(summary.kept, 1u);
    EXPECT_FALSE(s.pairs[0].polished);
    EXPECT_TRUE(s.pairs[0].chosen.T_target_source.isApprox(chosen, 0.0));
    EXPECT_TRUE(s.pairs[0].chosen.information.isApprox(Matrix6d::Identity(), 0.0));
}

TEST(EdgePolish, LeavesPairsTheConsensusDroppedAndDoesNothingWithoutBounds) {
    Vector6d nudge;
    nudge << 0.0, 0.0, 0.3 * kDeg, 0.04, -0.03, 0.0;
    StreetPair s = street_pair(nudge);
    const Eigen::Isometry3d chosen = s.pairs[0].chosen.T_target_source;
    EdgePolishSummary summary = polish_edges(s.features, {false}, EdgePolishParams{}, &s.pairs);
    EXPECT_EQ(summary.polished + summary.kept, 0u);
    EXPECT_TRUE(s.pairs[0].chosen.T_target_source.isApprox(chosen, 0.0));

    EdgePolishParams none;
    none.max_correspondence_m.clear();
    summary = polish_edges(s.features, {true}, none, &s.pairs);
    EXPECT_EQ(summary.polished + summary.kept, 0u);
    EXPECT_FALSE(s.pairs[0].polished);
    EXPECT_TRUE(s.pairs[0].chosen.T_target_source.isApprox(chosen, 0.0));
}

// Without polish clouds (polish_voxel_size_m = 0) the runs use the G-ICP clouds.
TEST(EdgePolish, FallsBackToTheGicpCloudsWithoutPolishClouds) {
    Vector6d nudge;
    nudge << 0.0, 0.0, 0.3 * kDeg, 0.04, -0.03, 0.0;
    StreetPair s = street_pair(nudge);
    for (SensorFeatures& f : s.features) f.polish = GicpCloud();
    const double before_m = translation_error_m(s.pairs[0].chosen.T_target_source, s.truth);
    const EdgePolishSummary summary =
        polish_edges(s.features, {true}, EdgePolishParams{}, &s.pairs);
    EXPECT_EQ(summary.polished, 1u);
    EXPECT_LT(translation_error_m(s.pairs[0].chosen.T_target_source, s.truth), 0.5 * before_m);
}

}  // namespace
}  // namespace lidarfuse::core
