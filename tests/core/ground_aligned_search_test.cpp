// The yaw/translation vote in levelled ground frames on the synthetic street: the true
// relative pose is among the strongest peaks for sensors 100 degrees apart, the output is
// deterministic, and bad input gives no candidate.
#include "core/initial/ground_aligned_search.hpp"

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "core/features/sensor_features.hpp"
#include "tests/core/street_features.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

namespace lidarfuse::core {
namespace {

using testing::street_features;

GroundAlignedKeypoints keypoints_of(const SensorFeatures& f) {
    return {&f.keypoint_points, &f.keypoint_normals, &f.descriptors, f.ground.T_ground_sensor};
}

TEST(GroundAlignedSearch, TruthIsAmongTheStrongestPeaks) {
    const SensorFeatures target = street_features(0);
    const SensorFeatures source = street_features(2);
    ASSERT_TRUE(target.ground.found);
    ASSERT_TRUE(source.ground.found);
    const auto poses = testing::street_sensor_poses();
    const Eigen::Isometry3d truth = poses[0].inverse() * poses[2];
    const auto candidates = ground_aligned_search(keypoints_of(source), keypoints_of(target));
    ASSERT_FALSE(candidates.empty());
    int found = -1;
    for (std::size_t k = 0; k < candidates.size() && found < 0; ++k) {
        if (translation_error_m(candidates[k].T_target_source, truth) < 1.5 &&
            rotation_error_deg(candidates[k].T_target_source, truth) < 2.0) {
            found = static_cast<int>(k);
        }
    }
    ASSERT_GE(found, 0);
    EXPECT_LE(found, 2);
    EXPECT_GE(candidates[found].votes, GroundAlignedSearchParams{}.min_votes);
    EXPECT_GE(candidates[found].inliers.size(), 6u);
    for (std::size_t k = 1; k < candidates.size(); ++k)
        EXPECT_GE(candidates[k - 1].votes, candidates[k].votes);

    const auto again = ground_aligned_search(keypoints_of(source), keypoints_of(target));
    ASSERT_EQ(again.size(), candidates.size());
    for (std::size_t k = 0; k < again.size(); ++k) {
        EXPECT_TRUE(again[k].T_target_source.isApprox(candidates[k].T_target_source, 0.0));
    }
}

TEST(GroundAlignedSearch, BadInputGivesNoCandidate) {
    const SensorFeatures f = street_features(0);
    EXPECT_TRUE(ground_aligned_search({}, keypoints_of(f)).empty());
    std::vector<Eigen::Vector3d> two(2, Eigen::Vector3d::Zero());
    std::vector<FpfhDescriptor> d2(2, FpfhDescriptor::Zero());
    EXPECT_TRUE(
        ground_aligned_search({&two, &two, &d2, Eigen::Isometry3d::Identity()}, keypoints_of(f))
            .empty());
    GroundAlignedSearchParams bad;
    bad.cell_m = 0.0;
    EXPECT_TRUE(ground_aligned_search(keypoints_of(f), keypoints_of(f), bad).empty());
}

}  // namespace
}  // namespace lidarfuse::core
