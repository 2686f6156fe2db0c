#pragma once
// Ours (not in the paper): the fused cloud thinned to one point per occupied voxel, for
// consumers that cannot take every point at sensor rate (a laptop's live view over Wi-Fi, a
// station's cloud sent to a segment daemon, recording at a lower volume).
//
// The voxels are a grid fixed in the fused cloud's frame (its axes and origin; metres), so a
// static surface thins to the same points frame after frame. Static and dynamic points
// never share a voxel: a vehicle keeps its own points and does not blur into the road
// under it. Per occupied voxel, in the order of its first point in the input:
//   point      the centroid of its points (summed in double)
//   intensity  their mean
//   sensor     the sensor of its first point (the voxel mixes sensors where they overlap)
//   dynamic    the voxel's flag
// Points that are not finite or lie beyond the grid (+-2^20 voxels per axis) are left out.
//
// O(n); buffers kept between calls (no allocation per frame once grown). Not thread safe: one
// object per thread.
#include <cstdint>
#include <vector>

#include "core/pipeline/fusion_types.hpp"

namespace lidarfuse::core {

class FusedCloudVoxels {
public:
    // `out` is overwritten; voxel_size_m > 0 (else `out` is left empty).
    void downsample(const FusedCloud& in, double voxel_size_m, FusedCloud* out);

private:
    struct Slot {
        std::uint64_t key;
        std::uint32_t voxel;
    };
    // The voxel of `key`, appended when it is new (the table grows as needed).
    std::uint32_t voxel_of(std::uint64_t key, std::uint8_t sensor);
    std::uint32_t add_voxel(std::uint64_t key, std::uint8_t sensor);
    std::size_t slot_of(std::uint64_t key) const;
    void reserve_slots(std::size_t voxels);

    // Open addressing sized by the voxels (the last call's count), doubled when a cloud has
    // more. A fine grid's table outgrows the cache and a probe costs a miss, so a small
    // direct-mapped table of recent voxels answers first: a sensor's next scan row mostly
    // falls in the voxels of the row before.
    static constexpr int kRecentBits = 12;
    std::vector<Slot> slots_;
    std::vector<Slot> recent_;
    int hash_shift_ = 64;
    std::vector<std::uint64_t> voxel_keys_;
    struct Sums {  // one voxel's, together: one cache line per point added
        Eigen::Vector3d point = Eigen::Vector3d::Zero();
        double intensity = 0.0;
        std::uint32_t count = 0;
    };
    std::vector<Sums> sums_;
    std::vector<std::uint8_t> sensor_;
    std::vector<std::uint8_t> dynamic_;
};

}  // namespace lidarfuse::core
