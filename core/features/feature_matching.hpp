#pragma once
// Putative correspondences between two keypoint sets by descriptor matching (PAPER.md
// step 5): nearest neighbors in descriptor space (nanoflann k-d tree over the 33-D FPFH
// histograms, L2), filtered by Lowe's ratio test and/or a mutual-nearest check.

#include <cstddef>
#include <vector>

#include "core/features/fpfh.hpp"
#include "core/registration/correspondence.hpp"

namespace lidarfuse::core {

struct FeatureMatchingParams {
    // Keep a match only if the source's nearest target is also the target's nearest
    // source.
    bool mutual = false;
    // Lowe's ratio test: keep a match only if d1 <= ratio * d2 (distances to the nearest
    // and second nearest target). 1 disables the test.
    double ratio = 1.0;
    // When > 1 and `mutual` is off, every source keypoint contributes its
    // `candidates_per_source` nearest targets (more recall for RANSAC; the ratio test then
    // applies to the first only).
    int candidates_per_source = 3;
    // Descriptor distances above this are dropped (histogram units; <= 0: no bound).
    double max_descriptor_distance = 0.0;
};

// `source` and `target` are the descriptors of the two keypoint sets; the returned
// correspondences index them, ordered by source index.
Correspondences match_features(const std::vector<FpfhDescriptor>& source,
                               const std::vector<FpfhDescriptor>& target,
                               const FeatureMatchingParams& params = {});

}  // namespace lidarfuse::core
