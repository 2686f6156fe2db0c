#include "core/graph/pose_graph.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/graph/relative_pose_error.hpp"

namespace lidarfuse::core {
namespace {

constexpr double kDeg = M_PI / 180.0;

Eigen::Isometry3d pose(double x, double y, double z, double yaw_deg, double roll_deg = 0.0) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(x, y, z);
    return T;
}

// Measurement of T_a_b with right-perturbation noise of the given sigmas.
Eigen::Isometry3d noisy(std::mt19937& rng, const Eigen::Isometry3d& T, double sigma_rot_rad,
                        double sigma_trans_m) {
    std::normal_distribution<double> g(0.0, 1.0);
    Vector6d xi;
    for (int i = 0; i < 3; ++i) xi(i) = sigma_rot_rad * g(rng);
    for (int i = 3; i < 6; ++i) xi(i) = sigma_trans_m * g(rng);
    return T * se3_exp(xi);
}

Matrix6d information(double sigma_rot_rad, double sigma_trans_m) {
    Vector6d d;
    d << Eigen::Vector3d::Constant(1.0 / (sigma_rot_rad * sigma_rot_rad)),
        Eigen::Vector3d::Constant(1.0 / (sigma_trans_m * sigma_trans_m));
    return d.asDiagonal();
}

// Six poses on a ring (sensors around a junction), consecutive edges plus chords.
class PoseGraphLoop : public ::testing::Test {
protected:
    void SetUp() override {
        for (int i = 0; i < 6; ++i) {
            const double a = i * 60.0;
            truth_.push_back(pose(10 * std::cos(a * kDeg), 10 * std::sin(a * kDeg), 0.3 * i,
                                  a + 180.0, 2.0 * i));
        }
    }
    std::vector<Eigen::Isometry3d> truth_;
};

TEST_F(PoseGraphLoop, NoisyLoopWithOneOutlierIsConsistentAndTheOutlierDownWeighted) {
    std::mt19937 rng(4);
    const double s_rot = 0.1 * kDeg, s_trans = 0.01;
    PoseGraphParams params;
    params.huber_delta = 3.0;
    PoseGraph graph(params);
    std::normal_distribution<double> g(0.0, 1.0);
    for (int i = 0; i < 6; ++i) {
        // Initial values: truth perturbed by ~0.3 m and ~3 degrees (except the root).
        Eigen::Isometry3d init = truth_[i];
        if (i > 0) {
            Vector6d xi;
            for (int k = 0; k < 3; ++k) xi(k) = 3.0 * kDeg * g(rng);
            for (int k = 3; k < 6; ++k) xi(k) = 0.3 * g(rng);
            init = init * se3_exp(xi);
        }
        ASSERT_TRUE(graph.add_node(100 + i, init, /*fixed=*/i == 0));
    }
    EXPECT_FALSE(graph.add_node(100, Eigen::Isometry3d::Identity()));  // duplicate id
    std::vector<PoseGraph::EdgeId> good;
    auto add = [&](int a, int b) {
        const Eigen::Isometry3d T_ab = truth_[a].inverse() * truth_[b];
        const auto id = graph.add_edge(100 + a, 100 + b, noisy(rng, T_ab, s_rot, s_trans),
                                       information(s_rot, s_trans));
        EXPECT_GE(id, 0);
        good.push_back(id);
    };
    for (int i = 0; i < 6; ++i) add(i, (i + 1) % 6);
    add(0, 3);
    add(1, 4);
    add(2, 5);
    // The outlier: 2 -> 4 off by 1.5 m and 10 degrees.
    const Eigen::Isometry3d wrong = truth_[2].inverse() * truth_[4] * pose(1.5, 0, 0, 10);
    const auto outlier = graph.add_edge(102, 104, wrong, information(s_rot, s_trans));
    ASSERT_GE(outlier, 0);

    const PoseGraphSummary summary = graph.optimize();
    ASSERT_TRUE(summary.usable) << summary.message;
    EXPECT_EQ(summary.num_nodes, 6u);
    EXPECT_EQ(summary.num_edges, 10u);
    EXPECT_LT(summary.final_cost, summary.initial_cost);

    // Poses agree with the truth to a few edge sigmas despite the outlier.
    for (int i = 0; i < 6; ++i) {
        const Eigen::Isometry3d est = *graph.node_pose(100 + i);
        EXPECT_LT(translation_error_m(est, truth_[i]), 0.05) << "node " << i;
        EXPECT_LT(rotation_error_deg(est, truth_[i]), 0.3) << "node " << i;
    }
    EXPECT_TRUE(graph.node_pose(100)->isApprox(truth_[0]));  // the gauge did not move

    // The outlier is far outside Huber's quadratic zone; the good edges are inside or close.
    const EdgeResidual bad = *graph.edge_residual(outlier);
    EXPECT_LT(bad.robust_weight, 0.05);
    EXPECT_GT(bad.translation_m, 1.0);
    for (const auto id : good) {
        const EdgeResidual r = *graph.edge_residual(id);
        EXPECT_GT(r.robust_weight, 0.3) << "edge " << id;
        EXPECT_LT(r.translation_m, 0.1);
    }
}

TEST_F(PoseGraphLoop, WithoutHuberTheOutlierPullsTheSolution) {
    // Same graph, quadratic loss: the outlier visibly distorts the poses. This shows the
    // previous test's accuracy is due to the robust loss.
    std::mt19937 rng(4);
    PoseGraphParams params;
    params.huber_delta = 0.0;
    PoseGraph graph(params);
    for (int i = 0; i < 6; ++i) graph.add_node(i, truth_[i], i == 0);
    const double s_rot = 0.1 * kDeg, s_trans = 0.01;
    for (int i = 0; i < 6; ++i) {
        const int j = (i + 1) % 6;
        graph.add_edge(i, j, truth_[i].inverse() * truth_[j], information(s_rot, s_trans));
    }
    graph.add_edge(2, 4, truth_[2].inverse() * truth_[4] * pose(1.5, 0, 0, 10),
                   information(s_rot, s_trans));
    ASSERT_TRUE(graph.optimize().usable);
    double worst = 0.0;
    for (int i = 0; i < 6; ++i)
        worst = std::max(worst, translation_error_m(*graph.node_pose(i), truth_[i]));
    EXPECT_GT(worst, 0.2);
}

// The residual's tangent convention is G-ICP's: with T_b = T_a * Z * exp(delta) (right
// perturbation of the measurement, order [omega; v]) the unwhitened residual is delta to
// first order, so a G-ICP Hessian can be used as the information unchanged.
TEST(RelativePoseError, MatchesTheRightPerturbationConvention) {
    const Eigen::Isometry3d T_a = pose(1, 2, 3, 40, 10);
    const Eigen::Isometry3d Z = pose(-2, 0.5, 0.1, -70, 4);
    Vector6d delta;
    delta << 2e-5, -1e-5, 3e-5, 4e-5, -2e-5, 1e-5;
    const Eigen::Isometry3d T_b = T_a * Z * se3_exp(delta);
    const RelativePoseError error(Z, Matrix6d::Identity());
    const Eigen::Quaterniond q_a(T_a.linear()), q_b(T_b.linear());
    const Eigen::Vector3d t_a = T_a.translation(), t_b = T_b.translation();
    Vector6d r;
    error(q_a.coeffs().data(), t_a.data(), q_b.coeffs().data(), t_b.data(), r.data());
    // Second-order terms remain (~|delta|^2); a wrong convention would be off by ~|delta|.
    EXPECT_LT((r - delta).norm(), 2.0 * delta.squaredNorm()) << r.transpose();
    // Whitening: r = S delta.
    Matrix6d S = Matrix6d::Identity();
    S(0, 0) = 10.0;
    S(4, 1) = 2.0;
    const RelativePoseError whitened(Z, S);
    whitened(q_a.coeffs().data(), t_a.data(), q_b.coeffs().data(), t_b.data(), r.data());
    EXPECT_LT((r - S * delta).norm(), 20.0 * delta.squaredNorm()) << r.transpose();
}

TEST(PoseGraph, ChainReachesANodeWithoutADirectEdgeToTheRoot) {
    // root -> a -> b, no root-b edge; b starts far off.
    const Eigen::Isometry3d T_root_a = pose(5, 1, 0.5, 30, 5);
    const Eigen::Isometry3d T_a_b = pose(4, -2, 0.2, -50, -3);
    PoseGraph graph;
    graph.add_node(0, Eigen::Isometry3d::Identity(), true);
    graph.add_node(1, Eigen::Isometry3d::Identity());
    graph.add_node(2, pose(-3, 3, 1, 90));
    EXPECT_GE(graph.add_edge(0, 1, T_root_a, Matrix6d::Identity() * 100), 0);
    EXPECT_GE(graph.add_edge(1, 2, T_a_b, Matrix6d::Identity() * 100), 0);
    const PoseGraphSummary s = graph.optimize();
    ASSERT_TRUE(s.usable) << s.message;
    EXPECT_TRUE(s.converged) << s.message;
    const Eigen::Isometry3d expected = T_root_a * T_a_b;
    EXPECT_LT(translation_error_m(*graph.node_pose(2), expected), 1e-6);
    EXPECT_LT(rotation_error_deg(*graph.node_pose(2), expected), 1e-5);
}

TEST(PoseGraph, SlidingWindowAddRemoveKeepsWorking) {
    // A sensor moving along x by 0.1 m per frame, window of 3 frames plus frame 0.
    PoseGraph graph;
    auto truth = [](int f) { return pose(0.1 * f, 0, 0, 0.5 * f); };
    graph.add_node(0, truth(0), true);
    std::vector<PoseGraph::EdgeId> edges_of_removed;
    for (int f = 1; f <= 10; ++f) {
        graph.add_node(f, graph.node_pose(f - 1).value());  // initial: previous estimate
        graph.add_edge(f - 1, f, truth(f - 1).inverse() * truth(f), Matrix6d::Identity() * 1e4);
        graph.add_edge(0, f, truth(0).inverse() * truth(f), Matrix6d::Identity() * 1e2);
        if (f - 3 >= 1) {
            EXPECT_TRUE(graph.remove_node(f - 3));
            EXPECT_FALSE(graph.has_node(f - 3));
        }
        const PoseGraphSummary s = graph.optimize();
        ASSERT_TRUE(s.usable) << "frame " << f << ": " << s.message;
        EXPECT_LT(translation_error_m(*graph.node_pose(f), truth(f)), 1e-6) << "frame " << f;
    }
    EXPECT_EQ(graph.num_nodes(), 4u);  // 0, 8, 9, 10
    EXPECT_EQ(graph.node_ids(), (std::vector<PoseGraph::NodeId>{0, 8, 9, 10}));
    EXPECT_FALSE(graph.remove_node(3));
}

TEST(PoseGraph, RejectsBadEdgesAndHandlesEmptyGraphs) {
    PoseGraph graph;
    EXPECT_TRUE(graph.optimize().usable);  // nothing to do
    graph.add_node(1, Eigen::Isometry3d::Identity(), true);
    graph.add_node(2, Eigen::Isometry3d::Identity());
    EXPECT_EQ(graph.add_edge(1, 3, Eigen::Isometry3d::Identity(), Matrix6d::Identity()), -1);
    EXPECT_EQ(graph.add_edge(1, 1, Eigen::Isometry3d::Identity(), Matrix6d::Identity()), -1);
    EXPECT_EQ(graph.add_edge(1, 2, Eigen::Isometry3d::Identity(), Matrix6d::Zero()), -1);
    Matrix6d nan_info = Matrix6d::Identity();
    nan_info(0, 0) = std::nan("");
    EXPECT_EQ(graph.add_edge(1, 2, Eigen::Isometry3d::Identity(), nan_info), -1);
    // A rank-deficient G-ICP Hessian (single plane) is not positive definite either.
    Matrix6d rank_deficient = Matrix6d::Identity();
    rank_deficient(3, 3) = 0.0;
    EXPECT_EQ(graph.add_edge(1, 2, Eigen::Isometry3d::Identity(), rank_deficient), -1);
    EXPECT_EQ(graph.num_edges(), 0u);
    const auto id = graph.add_edge(1, 2, pose(1, 0, 0, 0), Matrix6d::Identity());
    ASSERT_GE(id, 0);
    EXPECT_TRUE(graph.remove_edge(id));
    EXPECT_FALSE(graph.remove_edge(id));
    EXPECT_FALSE(graph.edge_residual(id).has_value());
    EXPECT_FALSE(graph.node_pose(7).has_value());
}

}  // namespace
}  // namespace lidarfuse::core
