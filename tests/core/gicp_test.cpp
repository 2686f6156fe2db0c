#include "core/registration/gicp.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "core/preprocess/normals.hpp"
#include "tests/core/synthetic_scene.hpp"

namespace lidarfuse::core {
namespace {

GicpCloud with_covariances(std::vector<Eigen::Vector3d> points) {
    PointCloud cloud;
    cloud.points = std::move(points);
    NormalParams params;
    params.k_neighbors = 15;
    return GicpCloud(std::move(cloud), params, 10, 2);
}

// An independent, noisy sampling of the scene seen from T_true^-1 (2 cm range-like noise).
GicpCloud noisy_resampled_source(std::mt19937& rng, const Eigen::Isometry3d& T_true) {
    std::vector<Eigen::Vector3d> world = test::make_structured_scene(rng);
    test::add_gaussian_noise(rng, 0.02, &world);
    return with_covariances(test::transformed(T_true.inverse(), world));
}

void expect_finite(const GicpResult& r) {
    EXPECT_TRUE(r.T_target_source.matrix().allFinite());
    EXPECT_TRUE(r.H.allFinite());
    EXPECT_TRUE(r.b.allFinite());
    EXPECT_TRUE(std::isfinite(r.error));
    EXPECT_TRUE(std::isfinite(r.inlier_ratio));
}

class GicpScene : public ::testing::Test {
protected:
    void SetUp() override {
        std::mt19937 rng(42);
        target_points_ = test::make_structured_scene(rng);
        target_ = with_covariances(target_points_);
    }
    std::vector<Eigen::Vector3d> target_points_;
    GicpCloud target_;
};

TEST_F(GicpScene, IdentityWhenSourceEqualsTarget) {
    const GicpCloud source = with_covariances(target_points_);
    const GicpResult r = align_gicp(target_, source, Eigen::Isometry3d::Identity());
    ASSERT_TRUE(r.converged) << to_string(r.status);
    EXPECT_LT(r.T_target_source.translation().norm(), 1e-9);
    EXPECT_LT(rotation_error_rad(r.T_target_source, Eigen::Isometry3d::Identity()), 1e-9);
    EXPECT_EQ(r.num_inliers, source.size());
    EXPECT_DOUBLE_EQ(r.inlier_ratio, 1.0);
    EXPECT_LT(r.rmse_m, 1e-9);
    EXPECT_LE(r.iterations, 2);
    EXPECT_LT(r.reduced_chi2, 1e-12);
}

// Source = the target's points seen from another pose: exact correspondences exist, so
// the optimum is the true transform to numerical precision.
TEST_F(GicpScene, RecoversKnownTransformsWithoutNoise) {
    std::mt19937 rng(3);
    GicpParams params;
    params.max_correspondence_distance_m = 3.0;
    params.max_iterations = 60;
    params.translation_eps_m = 1e-6;
    params.rotation_eps_rad = 1e-7;
    GicpRegistration registration(params);
    for (int trial = 0; trial < 6; ++trial) {
        const double t_m = 0.2 + 0.16 * trial;                  // up to 1 m
        const double angle = (2.0 + 1.6 * trial) * M_PI / 180;  // up to 10 degrees
        const Eigen::Isometry3d T_true = test::random_transform(rng, t_m, angle);
        const GicpCloud source =
            with_covariances(test::transformed(T_true.inverse(), target_points_));
        for (const GicpSolver solver :
             {GicpSolver::kLevenbergMarquardt, GicpSolver::kGaussNewton}) {
            params.solver = solver;
            registration.set_params(params);
            const GicpResult r = registration.align(target_, source, Eigen::Isometry3d::Identity());
            expect_finite(r);
            EXPECT_TRUE(r.converged) << "trial " << trial << " " << to_string(r.status);
            EXPECT_LT(translation_error_m(r.T_target_source, T_true), 1e-3) << "trial " << trial;
            EXPECT_LT(rotation_error_deg(r.T_target_source, T_true), 0.01) << "trial " << trial;
            EXPECT_GT(r.inlier_ratio, 0.99);
        }
    }
}

// Independently sampled source with 2 cm range-like noise: sampling and noise limit the
// accuracy; bounds a few times the noise divided by sqrt(points per constrained plane).
TEST_F(GicpScene, RecoversTransformWithIndependentSamplingAndNoise) {
    std::mt19937 rng(5);
    const Eigen::Isometry3d T_true = test::random_transform(rng, 0.8, 8.0 * M_PI / 180);
    const GicpCloud source = noisy_resampled_source(rng, T_true);
    GicpParams params;
    params.max_correspondence_distance_m = 3.0;
    params.max_iterations = 60;
    const GicpResult r = align_gicp(target_, source, Eigen::Isometry3d::Identity(), params);
    expect_finite(r);
    EXPECT_TRUE(r.converged) << to_string(r.status);
    EXPECT_LT(translation_error_m(r.T_target_source, T_true), 0.01);
    EXPECT_LT(rotation_error_deg(r.T_target_source, T_true), 0.05);
    // Noise and resampling leave a residual: the fitted scale is positive and finite.
    EXPECT_GT(r.reduced_chi2, 1e-4);
    EXPECT_TRUE(std::isfinite(r.reduced_chi2));
}

// 20% of the source replaced by uniform clutter: the robust kernels keep the estimate.
TEST_F(GicpScene, RobustKernelsTolerateOutliers) {
    std::mt19937 rng(9);
    const Eigen::Isometry3d T_true = test::random_transform(rng, 0.3, 3.0 * M_PI / 180);
    std::vector<Eigen::Vector3d> world = target_points_;
    std::uniform_real_distribution<double> u(-15.0, 15.0), h(0.0, 6.0);
    for (std::size_t i = 0; i < world.size(); i += 5)
        world[i] = Eigen::Vector3d(u(rng), u(rng), h(rng));
    const GicpCloud source = with_covariances(test::transformed(T_true.inverse(), world));
    for (const RobustKernel kernel : {RobustKernel::kHuber, RobustKernel::kGemanMcClure}) {
        GicpParams params;
        params.max_correspondence_distance_m = 1.5;
        params.kernel = kernel;
        params.kernel_scale = 1.0;
        params.max_iterations = 60;
        const GicpResult r = align_gicp(target_, source, Eigen::Isometry3d::Identity(), params);
        expect_finite(r);
        EXPECT_TRUE(r.converged) << to_string(r.status);
        EXPECT_LT(translation_error_m(r.T_target_source, T_true), 0.01);
        EXPECT_LT(rotation_error_deg(r.T_target_source, T_true), 0.05);
        EXPECT_LT(r.inlier_ratio, 0.95);  // the clutter is not all matched
    }
}

TEST_F(GicpScene, ThreadCountDoesNotChangeTheResult) {
    std::mt19937 rng(13);
    const Eigen::Isometry3d T_true = test::random_transform(rng, 0.5, 5.0 * M_PI / 180);
    const GicpCloud source = with_covariances(test::transformed(T_true.inverse(), target_points_));
    GicpParams params;
    params.max_correspondence_distance_m = 2.0;
    const GicpResult r1 = align_gicp(target_, source, Eigen::Isometry3d::Identity(), params, 1);
    const GicpResult r2 = align_gicp(target_, source, Eigen::Isometry3d::Identity(), params, 2);
    EXPECT_EQ(r1.iterations, r2.iterations);
    EXPECT_EQ(r1.num_inliers, r2.num_inliers);
    EXPECT_LT((r1.T_target_source.matrix() - r2.T_target_source.matrix()).norm(), 1e-9);
}

// Inside another parallel region (the initial registration runs pairs in parallel), the
// inner team may be smaller than num_threads; per-thread sums left over from an earlier
// call with a full team must not leak into the result.
TEST_F(GicpScene, NestedInAParallelRegionGivesTheSameResult) {
    std::mt19937 rng(19);
    const Eigen::Isometry3d T_true = test::random_transform(rng, 0.5, 5.0 * M_PI / 180);
    const GicpCloud source = with_covariances(test::transformed(T_true.inverse(), target_points_));
    GicpParams params;
    params.max_correspondence_distance_m = 2.0;
    GicpRegistration registration(params, 2);
    const GicpResult outside = registration.align(target_, source);
    GicpResult inside;
#pragma omp parallel num_threads(2)
    {
        if (omp_get_thread_num() == 0) inside = registration.align(target_, source);
    }
    EXPECT_EQ(outside.num_inliers, inside.num_inliers);
    EXPECT_LT(translation_error_m(inside.T_target_source, T_true), 1e-3);
    EXPECT_LT((outside.T_target_source.matrix() - inside.T_target_source.matrix()).norm(), 1e-9);
    EXPECT_LT((outside.H - inside.H).norm(), 1e-6 * outside.H.norm());
}

// The search shortcut (the previous neighbor and its listed neighbors, certified by the
// list's reach) is exact: without the lists every correspondence is searched, and the
// result is the same.
// Both solvers register `source` onto `target` and `other_source` onto `other_target` alike:
// the same iterations and inliers, T and H within `tolerance`, and near the truth.
void expect_same_registrations(const GicpCloud& target, const GicpCloud& source,
                               const GicpCloud& other_target, const GicpCloud& other_source,
                               double tolerance, const Eigen::Isometry3d& T_true) {
    GicpParams params;
    params.max_correspondence_distance_m = 3.0;
    params.max_iterations = 60;
    for (const GicpSolver solver : {GicpSolver::kLevenbergMarquardt, GicpSolver::kGaussNewton}) {
        params.solver = solver;
        const GicpResult a = align_gicp(target, source, Eigen::Isometry3d::Identity(), params);
        const GicpResult b =
            align_gicp(other_target, other_source, Eigen::Isometry3d::Identity(), params);
        ASSERT_TRUE(a.converged) << to_string(a.status);
        EXPECT_EQ(a.iterations, b.iterations);
        EXPECT_EQ(a.num_inliers, b.num_inliers);
        EXPECT_TRUE(a.T_target_source.matrix().isApprox(b.T_target_source.matrix(), tolerance));
        EXPECT_TRUE(a.H.isApprox(b.H, tolerance));
        EXPECT_NEAR(a.rmse_m, b.rmse_m, tolerance);
        EXPECT_LT(translation_error_m(a.T_target_source, T_true), 0.01);
    }
}

TEST_F(GicpScene, NeighborListsChangeNothingButTheSearches) {
    std::mt19937 rng(13);
    const Eigen::Isometry3d T_true = test::random_transform(rng, 0.5, 5.0 * M_PI / 180);
    const GicpCloud source = noisy_resampled_source(rng, T_true);
    ASSERT_TRUE(target_.has_neighbor_lists());
    CovarianceByproducts no_lists = target_.byproducts();
    no_lists.neighbor_list.clear();
    no_lists.reach_d2.clear();
    const GicpCloud searched(PointCloud(target_.cloud()), std::move(no_lists));
    ASSERT_FALSE(searched.has_neighbor_lists());
    ASSERT_TRUE(searched.has_plane_covariances());
    expect_same_registrations(target_, source, searched, source, 1e-12, T_true);
}

// A guess of the correspondences only bounds the first search: good guesses (the true
// ones), bad ones (random, out of range, none, the wrong length) and none at all give the
// same registration, bit for bit.
TEST_F(GicpScene, CorrespondenceGuessesChangeNothingButTheSearches) {
    std::mt19937 rng(17);
    const Eigen::Isometry3d T_true = test::random_transform(rng, 0.5, 5.0 * M_PI / 180);
    const GicpCloud source = noisy_resampled_source(rng, T_true);
    const Eigen::Isometry3d T_init =
        T_true * se3_exp((Vector6d() << 0.01, -0.02, 0.01, 0.1, 0.05, -0.1).finished());
    GicpRegistration plain;
    const GicpResult expected = plain.align(target_, source, T_init);
    ASSERT_TRUE(expected.converged);
    const std::vector<std::int32_t> found = plain.correspondences();
    ASSERT_EQ(found.size(), source.size());

    const auto n = static_cast<std::int32_t>(target_.size());
    std::uniform_int_distribution<std::int32_t> any(-5, n + 5);
    std::vector<std::int32_t> random(source.size());
    for (auto& j : random) j = any(rng);
    const std::vector<std::vector<std::int32_t>> guesses = {
        found, random, std::vector<std::int32_t>(source.size(), -1),
        std::vector<std::int32_t>(source.size() / 2, 0)};
    for (const auto& guess : guesses) {
        GicpRegistration guided;
        const GicpResult r = guided.align(target_, source, T_init, &guess);
        EXPECT_TRUE(r.T_target_source.matrix() == expected.T_target_source.matrix());
        EXPECT_EQ(r.iterations, expected.iterations);
        EXPECT_EQ(r.num_inliers, expected.num_inliers);
        EXPECT_TRUE(r.H == expected.H);
        EXPECT_EQ(guided.correspondences(), found);
    }
}

// The closed-form inverse of plane covariance pairs gives the matrices' result: without
// the axes (the 3x3 inverse), the same iterations, inliers, T and H up to rounding.
TEST_F(GicpScene, PlaneCovarianceAxesChangeNothingButTheInverse) {
    std::mt19937 rng(19);
    const Eigen::Isometry3d T_true = test::random_transform(rng, 0.5, 5.0 * M_PI / 180);
    const GicpCloud source = noisy_resampled_source(rng, T_true);
    ASSERT_TRUE(source.has_plane_covariances());
    ASSERT_TRUE(target_.has_plane_covariances());
    const GicpCloud matrices_only(source.cloud_with_covariance_matrices());
    ASSERT_TRUE(matrices_only.has_covariances());
    ASSERT_FALSE(matrices_only.has_plane_covariances());
    expect_same_registrations(target_, source, target_, matrices_only, 1e-9, T_true);
}

// Covariances computed on the target's own tree are the ones the two-step path gives.
TEST_F(GicpScene, TargetComputesTheSameCovariancesOnItsOwnTree) {
    NormalParams params;
    params.k_neighbors = 12;
    params.compute_normals = false;
    params.gicp_epsilon = 1e-2;
    PointCloud two_step;
    two_step.points = target_points_;
    CovarianceByproducts two_step_byproducts;
    estimate_normals_covariances(&two_step, &two_step_byproducts, KdTree(two_step.points), params);
    PointCloud bare;
    bare.points = target_points_;
    const GicpCloud target(std::move(bare), params);
    ASSERT_TRUE(target.has_covariances());
    ASSERT_TRUE(target.has_neighbor_lists());
    ASSERT_TRUE(target.has_plane_covariances());
    EXPECT_TRUE(target.cloud().normals.empty());
    EXPECT_EQ(target.points(), target_points_);
    EXPECT_EQ(target.byproducts().neighbor_list, two_step_byproducts.neighbor_list);
    EXPECT_EQ(target.byproducts().reach_d2, two_step_byproducts.reach_d2);
    EXPECT_EQ(target.byproducts().plane_axes, two_step_byproducts.plane_axes);
    EXPECT_TRUE(target.cloud().covariances.empty());  // held as the axes
    EXPECT_TRUE(two_step.covariances.empty());
    // And the tree is the one registration searches: a source registers onto it.
    const GicpCloud source = with_covariances(target_points_);
    const GicpResult r = align_gicp(target, source, Eigen::Isometry3d::Identity());
    EXPECT_TRUE(r.converged) << to_string(r.status);
    EXPECT_EQ(r.num_inliers, source.size());
}

TEST_F(GicpScene, OneTargetServesSeveralSourcesAndRegistrationIsReusable) {
    std::mt19937 rng(17);
    GicpParams params;
    params.max_correspondence_distance_m = 2.0;
    GicpRegistration registration(params);
    for (int i = 0; i < 3; ++i) {
        const Eigen::Isometry3d T_true = test::random_transform(rng, 0.4, 4.0 * M_PI / 180);
        const GicpCloud source =
            with_covariances(test::transformed(T_true.inverse(), target_points_));
        const GicpResult reused = registration.align(target_, source);
        const GicpResult fresh = align_gicp(target_, source, Eigen::Isometry3d::Identity(), params);
        EXPECT_LT(translation_error_m(reused.T_target_source, T_true), 1e-3);
        EXPECT_LT((reused.T_target_source.matrix() - fresh.T_target_source.matrix()).norm(), 1e-12);
        EXPECT_EQ(reused.iterations, fresh.iterations);
    }
    // A moved target keeps working (points stay at a fixed address inside).
    GicpCloud moved = std::move(target_);
    const GicpCloud source = with_covariances(target_points_);
    EXPECT_TRUE(registration.align(moved, source).converged);
}

// A clone is a cloud of its own (the original may go) that registers bit for bit alike.
TEST_F(GicpScene, CloneRegistersTheSameAsTheOriginal) {
    std::mt19937 rng(23);
    const Eigen::Isometry3d T_true = test::random_transform(rng, 0.5, 5.0 * M_PI / 180);
    const GicpCloud source = noisy_resampled_source(rng, T_true);
    const GicpResult expected = align_gicp(target_, source, Eigen::Isometry3d::Identity());
    GicpCloud clone = target_.clone();
    target_ = GicpCloud();
    ASSERT_TRUE(clone.has_neighbor_lists());
    ASSERT_TRUE(clone.has_plane_covariances());
    const GicpResult r = align_gicp(clone, source, Eigen::Isometry3d::Identity());
    ASSERT_TRUE(expected.converged);
    EXPECT_TRUE(r.T_target_source.matrix() == expected.T_target_source.matrix());
    EXPECT_TRUE(r.H == expected.H);
    EXPECT_EQ(r.iterations, expected.iterations);
}

TEST_F(GicpScene, HessianIsSymmetricPositiveDefiniteForStructure) {
    const GicpCloud source = with_covariances(target_points_);
    const GicpResult r = align_gicp(target_, source, Eigen::Isometry3d::Identity());
    EXPECT_LT((r.H - r.H.transpose()).norm(), 1e-12 * r.H.norm());
    Eigen::SelfAdjointEigenSolver<Matrix6d> eig(r.H);
    EXPECT_TRUE(r.H_eigenvalues.isApprox(eig.eigenvalues(), 1e-9));
    EXPECT_GT(r.H_eigenvalues(0), 0.0);
    // Every translation direction is constrained by some wall or the ground: the
    // translation block is far from the ~epsilon (1e-3) ratio of a single plane.
    const Eigen::Vector3d& et = r.H_translation_eigenvalues;
    EXPECT_GT(et(0) / et(2), 2e-2) << et.transpose();
}

TEST(Gicp, SinglePlaneIsReportedAsDegenerate) {
    std::mt19937 rng(21);
    std::vector<Eigen::Vector3d> plane;
    test::sample_rectangle(rng, {-10, -10, 0}, {20, 0, 0}, {0, 20, 0}, 3000, &plane);
    const GicpCloud target = with_covariances(plane);
    Eigen::Isometry3d T_true = Eigen::Isometry3d::Identity();
    T_true.translation() = Eigen::Vector3d(0.3, -0.2, 0.1);
    std::vector<Eigen::Vector3d> other;
    test::sample_rectangle(rng, {-10, -10, 0}, {20, 0, 0}, {0, 20, 0}, 3000, &other);
    const GicpCloud source = with_covariances(test::transformed(T_true.inverse(), other));
    const GicpResult r = align_gicp(target, source, Eigen::Isometry3d::Identity());
    expect_finite(r);
    // The out-of-plane parts (z, roll, pitch) are recovered ...
    EXPECT_NEAR(r.T_target_source.translation().z(), 0.1, 1e-3);
    // ... but in-plane translation and yaw are not constrained: three eigenvalues collapse.
    EXPECT_GE(r.H_eigenvalues(0), -1e-9 * r.H_eigenvalues(5));  // PSD up to rounding
    const Eigen::Vector3d& et = r.H_translation_eigenvalues;
    EXPECT_LT(et(1) / et(2), 5e-3) << et.transpose();
    EXPECT_GT(et(1), 0.0);
}

TEST(Gicp, EmptyAndTinyInputsFailCleanly) {
    std::mt19937 rng(1);
    const GicpCloud target = with_covariances(test::make_structured_scene(rng, 1.0));
    const GicpCloud empty_target;
    const GicpCloud empty_source;
    GicpResult r = align_gicp(target, empty_source, Eigen::Isometry3d::Identity());
    EXPECT_FALSE(r.converged);
    EXPECT_EQ(r.status, GicpStatus::kEmptyInput);
    expect_finite(r);

    const GicpCloud three = with_covariances({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
    r = align_gicp(target, three, Eigen::Isometry3d::Identity());
    EXPECT_FALSE(r.converged);
    EXPECT_EQ(r.status, GicpStatus::kTooFewCorrespondences);
    expect_finite(r);
    r = align_gicp(empty_target, three, Eigen::Isometry3d::Identity());
    EXPECT_EQ(r.status, GicpStatus::kEmptyInput);

    PointCloud bare;
    bare.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const GicpCloud no_cov(std::move(bare));
    r = align_gicp(target, no_cov, Eigen::Isometry3d::Identity());
    EXPECT_EQ(r.status, GicpStatus::kMissingCovariances);

    // No overlap at all: too few correspondences, the initial guess is returned unchanged.
    Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
    far.translation() = Eigen::Vector3d(500, 0, 0);
    r = align_gicp(target, with_covariances(test::make_structured_scene(rng, 1.0)), far);
    EXPECT_EQ(r.status, GicpStatus::kTooFewCorrespondences);
    EXPECT_TRUE(r.T_target_source.isApprox(far));
    EXPECT_EQ(r.num_inliers, 0u);
}

}  // namespace
}  // namespace lidarfuse::core
