#pragma once
// Voxel-grid downsampling (PAPER.md, continuous registration): one point per occupied
// voxel, the centroid of the points that fell in it.
//
// Runs every frame on ~65k points per sensor, so it is O(n) with an open-addressing hash
// on the integer voxel coordinates and keeps all its buffers between calls: use one
// VoxelGrid object per thread / sensor and call downsample() each frame (no allocation
// once the buffers have grown). Output order: voxels in the order their first point
// appears in the input, or in Morton order of their coordinates (VoxelGridParams); both
// deterministic.
//
// Not thread safe (it owns scratch buffers); separate objects are independent.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/point_cloud.hpp"

namespace lidarfuse::core {

struct VoxelGridParams {
    double voxel_size_m = 1.0;  // edge length of the cubic voxels, > 0
    // Voxels with fewer points are dropped (their points map to kNoVoxel).
    int min_points_per_voxel = 1;
    // Output in space-filling-curve order (Morton order of the voxel coordinates, relative to
    // the lowest on each axis) instead of the order of first appearance: neighbors in space
    // are then mostly neighbors in memory.
    bool spatial_order = false;
};

// Which input points went into each output voxel (CSR layout). Filled on request.
struct VoxelIndexMap {
    static constexpr std::uint32_t kNoVoxel = 0xFFFFFFFFu;
    // Per input point: the index of its output point, or kNoVoxel (non-finite, out of the
    // representable grid, or in a voxel dropped by min_points_per_voxel).
    std::vector<std::uint32_t> voxel_of_point;
    // Output point v was made from input points point_indices[offsets[v] .. offsets[v+1]).
    std::vector<std::uint32_t> offsets;
    std::vector<std::uint32_t> point_indices;
};

struct VoxelGridStats {
    std::size_t num_input = 0;
    std::size_t num_output = 0;
    std::size_t num_invalid = 0;         // non-finite or beyond the grid's range (~1e6 voxels)
    std::size_t num_dropped_sparse = 0;  // input points in voxels below min_points_per_voxel
};

// A voxel's integer coordinates floor(p / size) packed into 21 bits each (offset binary):
// +-2^20 voxels per axis, i.e. +-10 km at 1 cm voxels. Keys stay below 2^63 (bit 63 is
// free for a caller's flag) and all-ones is never a key. False for a point that is not
// finite or lies beyond the grid. `inv_size` = 1 / voxel size (1/m).
inline bool voxel_key(const Eigen::Vector3d& p, double inv_size, std::uint64_t* key) {
    constexpr int kBitsPerAxis = 21;
    constexpr std::int64_t kAxisOffset = std::int64_t{1} << (kBitsPerAxis - 1);
    if (!p.allFinite()) return false;
    const Eigen::Vector3d c = (p * inv_size).array().floor();
    if ((c.array().abs() >= static_cast<double>(kAxisOffset)).any()) return false;
    const auto packed = [](double v) {
        return static_cast<std::uint64_t>(static_cast<std::int64_t>(v) + kAxisOffset);
    };
    *key = (packed(c.x()) << (2 * kBitsPerAxis)) | (packed(c.y()) << kBitsPerAxis) | packed(c.z());
    return true;
}

// The slot of `key` in an open-addressing table of 2^(64 - shift) slots: Fibonacci hashing
// (multiply by 2^64 / golden ratio), whose high bits mix all three packed coordinates and
// keep neighboring voxels in nearby slots, which the cache likes (a full mix, MurmurHash3's
// finaliser, made thinning a fused cloud at 0.2 m twice as slow: a cache miss per probe).
inline std::size_t voxel_slot(std::uint64_t key, int shift) {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift);
}

class VoxelGrid {
public:
    // `out` gets points only (normals / covariances cleared). `index_map` may be null.
    // `twins` (may be null): per output point, the index of the previous call's output
    // point from the same voxel, or VoxelIndexMap::kNoVoxel (no such voxel then, or another
    // voxel size). Consecutive frames on a grid fixed in one frame share most voxels, and a
    // point's twin is where its registration correspondence most likely is.
    VoxelGridStats downsample(const std::vector<Eigen::Vector3d>& points,
                              const VoxelGridParams& params, PointCloud* out,
                              VoxelIndexMap* index_map = nullptr,
                              std::vector<std::uint32_t>* twins = nullptr);

private:
    // Open addressing: key -> voxel (in order of first appearance), with the output index
    // of each voxel; the previous call's table is kept for the twins.
    struct Table {
        std::vector<std::uint64_t> keys;
        std::vector<std::uint32_t> values;
        std::vector<std::uint32_t> output_of_voxel;
        int hash_shift = 64;
        double voxel_size_m = 0.0;
        // The slot holding `key`, or the empty slot where it would go (linear probing).
        std::size_t slot_of(std::uint64_t key) const;
        std::uint32_t find(std::uint64_t key) const;
        void reset(std::size_t voxels);
    };
    void insert_points(const std::vector<Eigen::Vector3d>& points, double voxel_size_m,
                       VoxelGridStats* stats);
    std::uint32_t voxel_of(std::uint64_t key);
    void grow_table();
    void emit_centroids(const VoxelGridParams& params, PointCloud* out, VoxelGridStats* stats);
    void fill_index_map(std::size_t n, std::size_t num_output, VoxelIndexMap* index_map) const;
    void find_twins(std::size_t num_output, std::vector<std::uint32_t>* twins) const;
    void order_voxels(bool spatial);

    Table table_;
    Table previous_;
    std::vector<std::uint64_t> voxel_keys_;
    std::vector<std::uint32_t> voxel_of_point_;
    std::vector<Eigen::Vector3d> sums_;
    std::vector<std::uint32_t> counts_;
    std::vector<std::uint32_t> emit_order_;  // voxel indices in output order
    std::vector<std::uint64_t> codes_;       // per voxel: its Morton code (spatial order)
    std::vector<std::uint32_t> sorted_;      // radix sort scratch
};

// Convenience: a one-off downsampling with a temporary VoxelGrid.
PointCloud voxel_downsample(const std::vector<Eigen::Vector3d>& points,
                            const VoxelGridParams& params);

}  // namespace lidarfuse::core
