#include "core/features/feature_matching.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace lidarfuse::core {
namespace {

std::vector<FpfhDescriptor> random_descriptors(int n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 100.0f);
    std::vector<FpfhDescriptor> d(n);
    for (auto& h : d) {
        for (int i = 0; i < kFpfhSize; ++i) h[i] = u(rng);
    }
    return d;
}

TEST(FeatureMatching, RecoversAKnownPermutation) {
    const auto source = random_descriptors(300, 1);
    std::vector<std::uint32_t> perm(source.size());
    for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = static_cast<std::uint32_t>(i);
    std::mt19937 rng(2);
    std::shuffle(perm.begin(), perm.end(), rng);
    std::normal_distribution<float> noise(0.0f, 0.5f);
    std::vector<FpfhDescriptor> target(source.size());
    for (std::size_t i = 0; i < source.size(); ++i) {
        target[perm[i]] = source[i];
        for (int k = 0; k < kFpfhSize; ++k) target[perm[i]][k] += noise(rng);
    }
    for (const bool mutual : {true, false}) {
        FeatureMatchingParams params;
        params.mutual = mutual;
        params.ratio = mutual ? 1.0 : 0.8;
        params.candidates_per_source = 1;
        const Correspondences matches = match_features(source, target, params);
        ASSERT_EQ(matches.size(), source.size()) << "mutual " << mutual;
        for (const Correspondence& c : matches) {
            EXPECT_EQ(c.target, perm[c.source]);
            EXPECT_LT(c.descriptor_distance, 10.0f);
        }
    }
}

// Source descriptors without a counterpart in the target are dropped by the mutual check
// and the ratio test, while the true pairs survive.
TEST(FeatureMatching, MutualAndRatioFilterAmbiguousMatches) {
    auto source = random_descriptors(50, 3);
    const auto target = random_descriptors(50, 4);
    // Source 0..24 are exact copies of targets 25..49; the rest have no counterpart.
    for (int i = 0; i < 25; ++i) source[i] = target[25 + i];
    FeatureMatchingParams params;
    params.mutual = true;
    params.ratio = 0.9;
    params.candidates_per_source = 1;
    const Correspondences matches = match_features(source, target, params);
    int correct = 0;
    for (const Correspondence& c : matches) {
        if (c.source < 25) {
            EXPECT_EQ(c.target, c.source + 25);
            ++correct;
        }
    }
    EXPECT_EQ(correct, 25);
    EXPECT_LT(matches.size(), 35u);  // most of the 25 unmatched sources are filtered out
    // Ordered by source index.
    EXPECT_TRUE(std::is_sorted(
        matches.begin(), matches.end(),
        [](const Correspondence& a, const Correspondence& b) { return a.source < b.source; }));
}

TEST(FeatureMatching, SeveralCandidatesAndDistanceBound) {
    const auto target = random_descriptors(40, 5);
    std::vector<FpfhDescriptor> source{target[7]};
    FeatureMatchingParams params;
    params.mutual = false;
    params.candidates_per_source = 3;
    const Correspondences three = match_features(source, target, params);
    ASSERT_EQ(three.size(), 3u);
    EXPECT_EQ(three[0].target, 7u);
    EXPECT_FLOAT_EQ(three[0].descriptor_distance, 0.0f);
    EXPECT_LE(three[1].descriptor_distance, three[2].descriptor_distance);
    params.max_descriptor_distance = 1.0;
    EXPECT_EQ(match_features(source, target, params).size(), 1u);
    EXPECT_TRUE(match_features({}, target, params).empty());
    EXPECT_TRUE(match_features(source, {}, params).empty());
}

}  // namespace
}  // namespace lidarfuse::core
