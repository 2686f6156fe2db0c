#pragma once
// A putative point-to-point correspondence between two clouds, as produced by descriptor
// matching and consumed by RANSAC: `source` and `target` index the keypoints (or points)
// of the source and target clouds. `descriptor_distance` is the L2 distance between the
// two descriptors (unitless, in histogram units).

#include <cstdint>
#include <vector>

namespace lidarfuse::core {

struct Correspondence {
    std::uint32_t source = 0;
    std::uint32_t target = 0;
    float descriptor_distance = 0.0f;
};

using Correspondences = std::vector<Correspondence>;

}  // namespace lidarfuse::core
