#include "core/initial/edge_consensus.hpp"

#include <gtest/gtest.h>

#include "core/common/se3.hpp"

namespace lidarfuse::core {
namespace {

Eigen::Isometry3d pose(double x, double y, double yaw_deg) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() =
        Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(x, y, 0.0);
    return T;
}

PairAlternative candidate(int index, const Eigen::Isometry3d& T, std::size_t support,
                          double error_m, double free_space_share) {
    PairAlternative a;
    a.candidate = index;
    a.T_target_source = T;
    a.information = Matrix6d::Identity();
    a.p2p_inliers = support;
    a.p2p_error_m = error_m;
    a.free_space_violation_share = free_space_share;
    return a;
}

PairResult pair(int source, int target, const PairAlternative& chosen,
                const std::vector<PairAlternative>& alternatives = {}) {
    PairResult p;
    p.source = source;
    p.target = target;
    p.status = PairStatus::kOk;
    p.chosen = chosen;
    p.alternatives = alternatives;
    return p;
}

// The figures measured on the synthetic street with the source cut to a 90-deg sector
// (edge_consensus.hpp): the right candidate clearly beats its look-alike; the look-alike
// pairs of the two wrong poses the sweep used to report are not decided either way.
TEST(EdgeConsensus, ClearlyBetterNeedsAMarginAndNoLoss) {
    const AmbiguityParams params;
    const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    const auto right = candidate(0, T, 682, 0.353, 0.007);
    const auto look_alike = candidate(1, T, 633, 0.429, 0.072);
    EXPECT_TRUE(clearly_better(right, look_alike, params));
    EXPECT_FALSE(clearly_better(look_alike, right, params));
    const auto a = candidate(0, T, 850, 0.448, 0.058), b = candidate(1, T, 847, 0.490, 0.046);
    EXPECT_FALSE(clearly_better(a, b, params));
    EXPECT_FALSE(clearly_better(b, a, params));
    const auto c = candidate(0, T, 678, 0.414, 0.077), d = candidate(1, T, 422, 0.397, 0.019);
    EXPECT_FALSE(clearly_better(c, d, params));
    EXPECT_FALSE(clearly_better(d, c, params));
    EXPECT_FALSE(clearly_better(right, right, params));
    // A look-alike on a small patch (curve seed 3, pair 3->1: N 0.176 vs 0.456 of the
    // source) loses whatever its error.
    const auto patch = candidate(1, T, 176, 0.250, 0.026),
               wide = candidate(0, T, 456, 0.349, 0.017);
    EXPECT_TRUE(clearly_better(wide, patch, params));
    EXPECT_FALSE(clearly_better(patch, wide, params));
}

// Two sensors: one pair, no cycle. Two candidates that fit about equally well must be
// refused, whichever has the larger support.
TEST(EdgeConsensus, TwoSensorsWithEquallyGoodCandidatesAreAmbiguous) {
    std::vector<PairResult> pairs{pair(1, 0, candidate(0, pose(12, 3, 40), 850, 0.448, 0.058),
                                       {candidate(5, pose(-20, 7, 170), 847, 0.490, 0.046)})};
    std::vector<bool> edge_ok{true};
    const EdgeConsensusResult r = select_consistent_edges(2, &pairs, &edge_ok, {});
    ASSERT_EQ(r.ambiguous.size(), 2u);
    EXPECT_FALSE(r.ambiguous[0]);
    EXPECT_TRUE(r.ambiguous[1]);
    EXPECT_EQ(r.rival_trees, 1);
    EXPECT_FALSE(edge_ok[0]);
    EXPECT_EQ(pairs[0].status, PairStatus::kAmbiguous);

    // The same pair without the ambiguity test keeps the larger support (the old guess).
    std::vector<PairResult> guessed{pair(1, 0, candidate(0, pose(12, 3, 40), 850, 0.448, 0.058),
                                         {candidate(5, pose(-20, 7, 170), 847, 0.490, 0.046)})};
    std::vector<bool> guessed_ok{true};
    EdgeConsensusParams off;
    off.ambiguity.enabled = false;
    select_consistent_edges(2, &guessed, &guessed_ok, off);
    EXPECT_TRUE(guessed_ok[0]);
    EXPECT_EQ(guessed[0].chosen.candidate, 0);
}

// Two sensors, and the candidate with the most support is the look-alike: the right one
// is clearly better on p2p error and free space at nearly the same support, so it wins.
TEST(EdgeConsensus, ClearlyBetterCandidateWinsOverLargerSupport) {
    const Eigen::Isometry3d right = pose(-11, -2, -100);
    std::vector<PairResult> pairs{pair(1, 0, candidate(2, pose(5, 20, 10), 700, 0.429, 0.072),
                                       {candidate(0, right, 682, 0.353, 0.007)})};
    std::vector<bool> edge_ok{true};
    const EdgeConsensusResult r = select_consistent_edges(2, &pairs, &edge_ok, {});
    EXPECT_FALSE(r.ambiguous[1]);
    ASSERT_TRUE(edge_ok[0]);
    EXPECT_EQ(pairs[0].status, PairStatus::kOk);
    EXPECT_EQ(pairs[0].chosen.candidate, 0);
    EXPECT_TRUE(pairs[0].chosen.T_target_source.isApprox(right));
    ASSERT_EQ(pairs[0].alternatives.size(), 1u);
    EXPECT_EQ(pairs[0].alternatives[0].candidate, 2);
}

// Three sensors that all overlap: a look-alike of pair (1,0) as good as the right
// candidate is vetoed by the cycle through sensor 2, so nothing is ambiguous.
TEST(EdgeConsensus, CycleDecidesBetweenEquallyGoodCandidates) {
    const Eigen::Isometry3d P1 = pose(8, 6, 180), P2 = pose(-11, -2, -100);
    std::vector<PairResult> pairs{pair(1, 0, candidate(0, pose(30, -4, 95), 850, 0.448, 0.058),
                                       {candidate(3, P1, 847, 0.490, 0.046)}),
                                  pair(2, 0, candidate(0, P2, 600, 0.40, 0.01)),
                                  pair(2, 1, candidate(0, P1.inverse() * P2, 500, 0.40, 0.01))};
    std::vector<bool> edge_ok{true, true, true};
    const EdgeConsensusResult r = select_consistent_edges(3, &pairs, &edge_ok, {});
    for (std::size_t i = 0; i < 3; ++i) EXPECT_FALSE(r.ambiguous[i]) << "sensor " << i;
    for (std::size_t e = 0; e < 3; ++e) EXPECT_TRUE(edge_ok[e]) << "pair " << e;
    EXPECT_EQ(pairs[0].chosen.candidate, 3);
    EXPECT_TRUE(pairs[0].chosen.T_target_source.isApprox(P1));
}

// A sensor that overlaps only one other (no cycle through it) with two equally good
// candidates is refused; the rest of the station is unaffected.
TEST(EdgeConsensus, OnlyTheUndecidedSensorIsRefused) {
    const Eigen::Isometry3d P1 = pose(8, 6, 180);
    std::vector<PairResult> pairs{pair(1, 0, candidate(0, P1, 900, 0.35, 0.01)),
                                  pair(2, 0, candidate(0, pose(1, 1, 0), 10, 0.9, 0.3)),
                                  pair(2, 1, candidate(0, pose(15, 2, 30), 400, 0.45, 0.03),
                                       {candidate(1, pose(-9, 12, 200), 410, 0.46, 0.03)})};
    pairs[1].status = PairStatus::kLowOverlap;
    std::vector<bool> edge_ok{true, false, true};
    const EdgeConsensusResult r = select_consistent_edges(3, &pairs, &edge_ok, {});
    EXPECT_FALSE(r.ambiguous[0]);
    EXPECT_FALSE(r.ambiguous[1]);
    EXPECT_TRUE(r.ambiguous[2]);
    EXPECT_TRUE(edge_ok[0]);
    EXPECT_EQ(pairs[0].status, PairStatus::kOk);
    EXPECT_EQ(pairs[1].status, PairStatus::kLowOverlap);
    EXPECT_FALSE(edge_ok[2]);
    EXPECT_EQ(pairs[2].status, PairStatus::kAmbiguous);
}

// Two sensors placed at each other's look-alike (a symmetric crossing: lidar5 where lidar7
// stands and the other way round, turned by 180 deg) explain the pairs as well as the right
// placements. When the sampled trees miss the right placement of both at once (here only
// the max-support tree is sampled), the moves from the winner find it: moving sensor 2 to
// its right place lands on sensor 3, which is moved too. The two sensors are then refused,
// never placed at the look-alike.
TEST(EdgeConsensus, SwappedLookAlikesFoundByMovesAreRefused) {
    const Eigen::Isometry3d P1 = pose(20, -5, 30), P2 = pose(40, 30, -60), P3 = pose(-30, 35, 120);
    // Each at the other's place, turned by 180 deg.
    Eigen::Isometry3d S2 = P2 * pose(0, 0, 180), S3 = P3 * pose(0, 0, 180);
    S2.translation() = P3.translation();
    S3.translation() = P2.translation();
    const auto both = [](int source, int target, const Eigen::Isometry3d& look_alike,
                         const Eigen::Isometry3d& right) {
        return pair(source, target, candidate(0, look_alike, 800, 0.40, 0.05),
                    {candidate(1, right, 790, 0.40, 0.05)});
    };
    const auto make_pairs = [&] {
        return std::vector<PairResult>{pair(1, 0, candidate(0, P1, 900, 0.35, 0.01)),
                                       both(2, 0, S2, P2), both(3, 0, S3, P3),
                                       both(2, 1, P1.inverse() * S2, P1.inverse() * P2),
                                       both(3, 2, S2.inverse() * S3, P2.inverse() * P3)};
    };
    EdgeConsensusParams params;
    params.samples = 1;

    params.moves = false;
    std::vector<PairResult> guessed = make_pairs();
    std::vector<bool> guessed_ok(guessed.size(), true);
    const EdgeConsensusResult without = select_consistent_edges(4, &guessed, &guessed_ok, params);
    EXPECT_FALSE(without.ambiguous[2]);
    EXPECT_TRUE(guessed_ok[1]);
    EXPECT_EQ(guessed[1].chosen.candidate, 0);  // the look-alike, kept: what moves prevent

    params.moves = true;
    std::vector<PairResult> pairs = make_pairs();
    std::vector<bool> edge_ok(pairs.size(), true);
    const EdgeConsensusResult r = select_consistent_edges(4, &pairs, &edge_ok, params);
    EXPECT_FALSE(r.ambiguous[0]);
    EXPECT_FALSE(r.ambiguous[1]);
    EXPECT_TRUE(r.ambiguous[2]);
    EXPECT_TRUE(r.ambiguous[3]);
    EXPECT_TRUE(edge_ok[0]);
    for (std::size_t e = 1; e < pairs.size(); ++e) {
        EXPECT_FALSE(edge_ok[e]) << "pair " << e;
        EXPECT_EQ(pairs[e].status, PairStatus::kAmbiguous) << "pair " << e;
    }
}

TEST(EdgeConsensus, NoGoodPairs) {
    std::vector<PairResult> pairs{PairResult{}};
    pairs[0].source = 1;
    pairs[0].target = 0;
    std::vector<bool> edge_ok{false};
    const EdgeConsensusResult r = select_consistent_edges(2, &pairs, &edge_ok, {});
    EXPECT_EQ(r.ambiguous, std::vector<bool>(2, false));
    EXPECT_EQ(r.rival_trees, 0);
    EXPECT_FALSE(edge_ok[0]);
}

// A weakly constrained pair (smallest Hessian eigenvalue per G-ICP inlier below the bound)
// decides a sensor alone when it is a bridge: a chain root - 1 - 2 with the weak pair 2-1
// refuses sensor 2 (and only it), the same weak pair closed into a triangle by a
// consistent pair 2-0 does not, and a strong bridge does not either.
TEST(EdgeConsensus, SensorsBeyondAWeakBridgeAreUnconfirmed) {
    const Eigen::Isometry3d T1 = pose(10, 0, 30), T2 = pose(20, 5, 60);  // T_root_sensor
    const auto with_information = [](PairAlternative a, double per_inlier) {
        a.gicp_inliers = 1000;
        a.min_hessian_eigenvalue = per_inlier * 1000;
        return a;
    };
    const auto strong_1_0 = with_information(candidate(0, T1, 900, 0.35, 0.01), 6.0);
    const auto weak_2_1 = with_information(candidate(0, T1.inverse() * T2, 700, 0.40, 0.02), 0.5);
    const auto strong_2_0 = with_information(candidate(0, T2, 800, 0.35, 0.01), 6.0);
    EdgeConsensusParams params;
    params.min_bridge_information_per_inlier = 2.2;

    std::vector<PairResult> chain{pair(1, 0, strong_1_0), pair(2, 1, weak_2_1)};
    std::vector<bool> chain_ok{true, true};
    const EdgeConsensusResult c = select_consistent_edges(3, &chain, &chain_ok, params);
    EXPECT_EQ(c.unconfirmed, (std::vector<bool>{false, false, true}));
    EXPECT_TRUE(chain_ok[0]);
    EXPECT_FALSE(chain_ok[1]);
    EXPECT_EQ(chain[1].status, PairStatus::kUnconfirmed);

    std::vector<PairResult> triangle{pair(1, 0, strong_1_0), pair(2, 1, weak_2_1),
                                     pair(2, 0, strong_2_0)};
    std::vector<bool> triangle_ok{true, true, true};
    const EdgeConsensusResult t = select_consistent_edges(3, &triangle, &triangle_ok, params);
    EXPECT_EQ(t.unconfirmed, (std::vector<bool>(3, false)));
    EXPECT_EQ(triangle_ok, (std::vector<bool>(3, true)));

    std::vector<PairResult> strong_chain{pair(1, 0, strong_1_0),
                                         pair(2, 1, with_information(weak_2_1, 2.5))};
    std::vector<bool> strong_ok{true, true};
    const EdgeConsensusResult s = select_consistent_edges(3, &strong_chain, &strong_ok, params);
    EXPECT_EQ(s.unconfirmed, (std::vector<bool>(3, false)));

    params.min_bridge_information_per_inlier = 0.0;  // off: the weak bridge is taken
    std::vector<PairResult> unchecked{pair(1, 0, strong_1_0), pair(2, 1, weak_2_1)};
    std::vector<bool> unchecked_ok{true, true};
    select_consistent_edges(3, &unchecked, &unchecked_ok, params);
    EXPECT_EQ(unchecked_ok, (std::vector<bool>{true, true}));
}

}  // namespace
}  // namespace lidarfuse::core
