#include "core/registration/ransac.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace lidarfuse::core {
namespace {

struct Problem {
    std::vector<Eigen::Vector3d> source;
    std::vector<Eigen::Vector3d> target;
    Correspondences correspondences;
    std::vector<bool> is_inlier;
};

// n correspondences, the first inlier_share of them true (with noise), then shuffled.
Problem make_problem(const Eigen::Isometry3d& T, int n, double inlier_share, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-20.0, 20.0);
    std::normal_distribution<double> noise(0.0, 0.02);
    Problem p;
    const int n_inliers = static_cast<int>(n * inlier_share);
    for (int i = 0; i < n; ++i) {
        const Eigen::Vector3d s(u(rng), u(rng), 0.2 * u(rng));
        p.source.push_back(s);
        if (i < n_inliers) {
            p.target.push_back(T * s + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
        } else {
            p.target.emplace_back(u(rng), u(rng), 0.2 * u(rng));
        }
    }
    std::vector<std::uint32_t> order(n);
    for (int i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(i);
    std::shuffle(order.begin(), order.end(), rng);
    for (int i = 0; i < n; ++i) {
        p.correspondences.push_back({static_cast<std::uint32_t>(i), order[i], 0.0f});
    }
    // Target indices are permuted: move the targets accordingly.
    std::vector<Eigen::Vector3d> permuted(n);
    for (int i = 0; i < n; ++i) permuted[order[i]] = p.target[i];
    p.target = permuted;
    for (int i = 0; i < n; ++i) p.is_inlier.push_back(i < n_inliers);
    return p;
}

Eigen::Isometry3d yaw_transform(double yaw_deg, const Eigen::Vector3d& t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() =
        Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = t;
    return T;
}

class RansacOutliers : public ::testing::TestWithParam<double> {};

TEST_P(RansacOutliers, RecoversKnownTransform) {
    const double outlier_share = GetParam();
    const Eigen::Isometry3d T = yaw_transform(150.0, Eigen::Vector3d(12.0, -4.0, 0.5));
    const Problem p = make_problem(T, 400, 1.0 - outlier_share, 11);
    RansacParams params;
    params.inlier_threshold_m = 0.2;
    const RansacResult r = ransac_registration(p.source, p.target, p.correspondences, params);
    ASSERT_TRUE(r.success);
    EXPECT_LT((r.T_target_source.translation() - T.translation()).norm(), 0.05);
    EXPECT_LT(Eigen::AngleAxisd(r.T_target_source.linear() * T.linear().transpose()).angle(),
              0.2 * M_PI / 180.0);
    int true_inliers = 0;
    for (std::uint32_t i : r.inliers) true_inliers += p.is_inlier[i] ? 1 : 0;
    const int expected = static_cast<int>(400 * (1.0 - outlier_share));
    EXPECT_GE(true_inliers, expected - 2);
    EXPECT_LE(static_cast<int>(r.inliers.size()) - true_inliers, 3);  // chance agreements
    EXPECT_GT(r.prerejected_samples, 0);
}

INSTANTIATE_TEST_SUITE_P(Shares, RansacOutliers, ::testing::Values(0.7, 0.8, 0.9));

TEST(Ransac, DeterministicForASeedAndSeedMatters) {
    const Eigen::Isometry3d T = yaw_transform(-70.0, Eigen::Vector3d(1.0, 2.0, 0.0));
    const Problem p = make_problem(T, 300, 0.15, 21);
    RansacParams params;
    params.inlier_threshold_m = 0.2;
    params.seed = 7;
    const RansacResult a = ransac_registration(p.source, p.target, p.correspondences, params);
    const RansacResult b = ransac_registration(p.source, p.target, p.correspondences, params);
    ASSERT_TRUE(a.success);
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.inliers, b.inliers);
    EXPECT_TRUE(a.T_target_source.isApprox(b.T_target_source, 0.0));
    params.seed = 8;
    const RansacResult c = ransac_registration(p.source, p.target, p.correspondences, params);
    ASSERT_TRUE(c.success);
    // A different random sequence: different samples drawn and rejected.
    EXPECT_NE(a.prerejected_samples, c.prerejected_samples);
}

// The only consistent transform flips the up axis: rejected, unless the check is disabled.
TEST(Ransac, UpVectorCheckRejectsUpsideDown) {
    Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
    flip.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    flip.translation() = Eigen::Vector3d(0, 0, 6);
    EXPECT_FALSE(keeps_up_vector(flip));
    EXPECT_TRUE(keeps_up_vector(yaw_transform(179.0, Eigen::Vector3d::Zero())));
    const Problem p = make_problem(flip, 100, 1.0, 4);
    RansacParams params;
    params.inlier_threshold_m = 0.2;
    const RansacResult rejected =
        ransac_registration(p.source, p.target, p.correspondences, params);
    EXPECT_FALSE(rejected.success);
    EXPECT_GT(rejected.upside_down_hypotheses, 0);
    params.reject_upside_down = false;
    const RansacResult accepted =
        ransac_registration(p.source, p.target, p.correspondences, params);
    ASSERT_TRUE(accepted.success);
    EXPECT_TRUE(accepted.T_target_source.isApprox(flip, 1e-2));
}

// Two sensors tilted 45 deg to opposite sides (the side units of a vehicle rig): their +z
// axes are 90 deg apart plus a little, so +z alone calls the right transform upside down;
// their road normals (the up directions) agree under it.
TEST(Ransac, UpVectorCheckUsesTheGivenUpDirections) {
    const Eigen::Matrix3d R_world_left =
        Eigen::AngleAxisd(46.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
    const Eigen::Matrix3d R_world_right =
        Eigen::AngleAxisd(-46.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
    Eigen::Isometry3d T_left_right = Eigen::Isometry3d::Identity();
    T_left_right.linear() = R_world_left.transpose() * R_world_right;
    const Eigen::Vector3d up_left = R_world_left.transpose() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d up_right = R_world_right.transpose() * Eigen::Vector3d::UnitZ();
    EXPECT_FALSE(keeps_up_vector(T_left_right));
    EXPECT_TRUE(keeps_up_vector(T_left_right, up_right, up_left));
    // Turned upside down about the road's x axis, it is refused with the same up directions.
    Eigen::Isometry3d flipped = T_left_right;
    flipped.linear() = R_world_left.transpose() *
                       Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * R_world_right;
    EXPECT_FALSE(keeps_up_vector(flipped, up_right, up_left));
}

TEST(Ransac, DegenerateInputs) {
    RansacParams params;
    EXPECT_FALSE(ransac_registration({}, {}, {}, params).success);
    std::vector<Eigen::Vector3d> pts{{0, 0, 0}, {1, 0, 0}};
    EXPECT_FALSE(ransac_registration(pts, pts, {{0, 0, 0.f}, {1, 1, 0.f}}, params).success);
    // Out-of-range indices are refused, not read.
    EXPECT_FALSE(
        ransac_registration(pts, pts, {{0, 0, 0.f}, {1, 5, 0.f}, {0, 1, 0.f}}, params).success);
    // Pure noise: no consensus of min_inliers.
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> u(-30.0, 30.0);
    std::vector<Eigen::Vector3d> s, t;
    Correspondences c;
    for (std::uint32_t i = 0; i < 200; ++i) {
        s.emplace_back(u(rng), u(rng), u(rng));
        t.emplace_back(u(rng), u(rng), u(rng));
        c.push_back({i, i, 0.f});
    }
    params.inlier_threshold_m = 0.1;
    params.min_inliers = 8;
    EXPECT_FALSE(ransac_registration(s, t, c, params).success);
}

}  // namespace
}  // namespace lidarfuse::core
