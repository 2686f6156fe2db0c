#include "core/preprocess/voxel_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lidarfuse::core {

namespace {
constexpr std::uint64_t kEmptyKey = std::numeric_limits<std::uint64_t>::max();
}  // namespace

std::size_t VoxelGrid::Table::slot_of(std::uint64_t key) const {
    const std::size_t mask = keys.size() - 1;
    std::size_t slot = voxel_slot(key, hash_shift);
    while (keys[slot] != key && keys[slot] != kEmptyKey) slot = (slot + 1) & mask;
    return slot;
}

std::uint32_t VoxelGrid::Table::find(std::uint64_t key) const {
    if (keys.empty()) return VoxelIndexMap::kNoVoxel;
    const std::size_t slot = slot_of(key);
    return keys[slot] == key ? values[slot] : VoxelIndexMap::kNoVoxel;
}

void VoxelGrid::find_twins(std::size_t num_output, std::vector<std::uint32_t>* twins) const {
    twins->assign(num_output, VoxelIndexMap::kNoVoxel);
    const bool comparable = previous_.voxel_size_m == table_.voxel_size_m;
    for (std::size_t v = 0; v < voxel_keys_.size(); ++v) {
        const std::uint32_t o = table_.output_of_voxel[v];
        if (o == VoxelIndexMap::kNoVoxel) continue;
        const std::uint32_t before =
            comparable ? previous_.find(voxel_keys_[v]) : VoxelIndexMap::kNoVoxel;
        if (before != VoxelIndexMap::kNoVoxel) (*twins)[o] = previous_.output_of_voxel[before];
    }
}

namespace {
// The 21 bits of one axis spread to every third bit (bit i -> bit 3 i).
inline std::uint64_t spread_bits(std::uint64_t v) {
    v &= 0x1FFFFFull;
    v = (v | v << 32) & 0x1F00000000FFFFull;
    v = (v | v << 16) & 0x1F0000FF0000FFull;
    v = (v | v << 8) & 0x100F00F00F00F00Full;
    v = (v | v << 4) & 0x10C30C30C30C30C3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

constexpr std::uint64_t kAxisMask = (std::uint64_t{1} << 21) - 1;

// Axis a (0: x, 1: y, 2: z) of a voxel key (voxel_key's offset binary).
inline std::uint64_t key_axis(std::uint64_t key, int a) {
    return (key >> (21 * (2 - a))) & kAxisMask;
}
}  // namespace

// The order in which the voxels are emitted: of first appearance, or the Morton order of
// their coordinates relative to the lowest on each axis (x in the highest of each three
// bits). Relative, so that the codes have few bits: a stable radix sort by bytes then takes
// 3-4 passes for a scan's few thousand voxels (std::sort took a millisecond per frame).
void VoxelGrid::order_voxels(bool spatial) {
    const std::size_t n = voxel_keys_.size();
    emit_order_.resize(n);
    for (std::size_t v = 0; v < n; ++v) emit_order_[v] = static_cast<std::uint32_t>(v);
    if (!spatial || n < 2) return;
    std::uint64_t low[3] = {kAxisMask, kAxisMask, kAxisMask};
    for (const std::uint64_t key : voxel_keys_)
        for (int a = 0; a < 3; ++a) low[a] = std::min(low[a], key_axis(key, a));
    codes_.resize(n);
    std::uint64_t all_bits = 0;
    for (std::size_t v = 0; v < n; ++v) {
        const std::uint64_t key = voxel_keys_[v];
        codes_[v] = spread_bits(key_axis(key, 0) - low[0]) << 2 |
                    spread_bits(key_axis(key, 1) - low[1]) << 1 |
                    spread_bits(key_axis(key, 2) - low[2]);
        all_bits |= codes_[v];
    }
    sorted_.resize(n);
    for (int shift = 0; shift < 64 && (all_bits >> shift) != 0; shift += 8) {
        std::size_t start[257] = {};
        for (const std::uint32_t v : emit_order_) ++start[((codes_[v] >> shift) & 0xFF) + 1];
        for (int d = 0; d < 256; ++d) start[d + 1] += start[d];
        for (const std::uint32_t v : emit_order_) sorted_[start[(codes_[v] >> shift) & 0xFF]++] = v;
        emit_order_.swap(sorted_);
    }
}

VoxelGridStats VoxelGrid::downsample(const std::vector<Eigen::Vector3d>& points,
                                     const VoxelGridParams& params, PointCloud* out,
                                     VoxelIndexMap* index_map, std::vector<std::uint32_t>* twins) {
    VoxelGridStats stats;
    stats.num_input = points.size();
    out->clear();
    if (twins) twins->clear();
    const std::size_t n = points.size();
    if (index_map) {
        index_map->voxel_of_point.assign(n, VoxelIndexMap::kNoVoxel);
        index_map->offsets.assign(1, 0);
        index_map->point_indices.clear();
    }
    std::swap(table_, previous_);
    table_.voxel_size_m = 0.0;
    table_.output_of_voxel.clear();
    voxel_keys_.clear();
    if (n == 0 || !(params.voxel_size_m > 0.0) || !std::isfinite(params.voxel_size_m)) {
        stats.num_invalid = n;
        return stats;
    }
    table_.voxel_size_m = params.voxel_size_m;
    insert_points(points, params.voxel_size_m, &stats);
    emit_centroids(params, out, &stats);
    if (index_map) fill_index_map(n, stats.num_output, index_map);
    if (twins) find_twins(stats.num_output, twins);
    return stats;
}

// An empty table of at least twice `voxels` slots (a power of two, load factor <= 0.5).
void VoxelGrid::Table::reset(std::size_t voxels) {
    std::size_t capacity = 16;
    int shift_bits = 4;
    while (capacity < 2 * voxels) {
        capacity <<= 1;
        ++shift_bits;
    }
    hash_shift = 64 - shift_bits;
    keys.assign(capacity, kEmptyKey);
    values.resize(capacity);
}

// Twice the slots, the voxels so far inserted again (their indices unchanged).
void VoxelGrid::grow_table() {
    table_.reset(table_.keys.size());
    for (std::size_t v = 0; v < voxel_keys_.size(); ++v) {
        const std::size_t slot = table_.slot_of(voxel_keys_[v]);
        table_.keys[slot] = voxel_keys_[v];
        table_.values[slot] = static_cast<std::uint32_t>(v);
    }
}

// Every point into the table (open addressing, linear probing, load factor <= 0.5),
// summed into its voxel. The table starts sized for the previous call's voxels, not for
// the points: a scan of 65k points fills a few thousand voxels, and a table sized for the
// points (1.5 MB) would not stay in the cache.
void VoxelGrid::insert_points(const std::vector<Eigen::Vector3d>& points, double voxel_size_m,
                              VoxelGridStats* stats) {
    const std::size_t n = points.size();
    const std::size_t expected = previous_.output_of_voxel.size();
    table_.reset(std::min(n, expected + expected / 4 + 64));
    voxel_of_point_.resize(n);
    sums_.clear();
    counts_.clear();

    const double inv_size = 1.0 / voxel_size_m;
    // Neighboring pixels of a scan row mostly share a voxel: the last key's voxel skips
    // the probe (the same sums in the same order).
    std::uint64_t last_key = kEmptyKey;
    std::uint32_t last_voxel = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d& p = points[i];
        voxel_of_point_[i] = VoxelIndexMap::kNoVoxel;
        std::uint64_t key = 0;
        if (!voxel_key(p, inv_size, &key)) {
            ++stats->num_invalid;
            continue;
        }
        if (key != last_key) {
            last_voxel = voxel_of(key);
            last_key = key;
        }
        voxel_of_point_[i] = last_voxel;
        sums_[last_voxel] += p;
        ++counts_[last_voxel];
    }
}

// The voxel of `key`, a new one (in order of first appearance) when the key is new.
std::uint32_t VoxelGrid::voxel_of(std::uint64_t key) {
    std::size_t slot = table_.slot_of(key);
    if (table_.keys[slot] == kEmptyKey) {
        if (2 * (voxel_keys_.size() + 1) > table_.keys.size()) {
            grow_table();
            slot = table_.slot_of(key);
        }
        table_.keys[slot] = key;
        table_.values[slot] = static_cast<std::uint32_t>(sums_.size());
        voxel_keys_.push_back(key);
        sums_.emplace_back(Eigen::Vector3d::Zero());
        counts_.push_back(0);
    }
    return table_.values[slot];
}

// One centroid per voxel with enough points, in the order of order_voxels().
void VoxelGrid::emit_centroids(const VoxelGridParams& params, PointCloud* out,
                               VoxelGridStats* stats) {
    const std::size_t num_voxels = sums_.size();
    const std::uint32_t min_points =
        static_cast<std::uint32_t>(std::max(1, params.min_points_per_voxel));
    table_.output_of_voxel.resize(num_voxels);
    out->points.reserve(num_voxels);
    order_voxels(params.spatial_order);
    for (const std::uint32_t v : emit_order_) {
        if (counts_[v] >= min_points) {
            table_.output_of_voxel[v] = static_cast<std::uint32_t>(out->points.size());
            out->points.push_back(sums_[v] / static_cast<double>(counts_[v]));
        } else {
            table_.output_of_voxel[v] = VoxelIndexMap::kNoVoxel;
            stats->num_dropped_sparse += counts_[v];
        }
    }
    stats->num_output = out->points.size();
}

// Counting sort of the input indices by output voxel (CSR).
void VoxelGrid::fill_index_map(std::size_t n, std::size_t num_output,
                               VoxelIndexMap* index_map) const {
    auto& offsets = index_map->offsets;
    offsets.assign(num_output + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t v = voxel_of_point_[i];
        if (v == VoxelIndexMap::kNoVoxel) continue;
        const std::uint32_t o = table_.output_of_voxel[v];
        index_map->voxel_of_point[i] = o;
        if (o != VoxelIndexMap::kNoVoxel) ++offsets[o + 1];
    }
    for (std::size_t v = 0; v < num_output; ++v) offsets[v + 1] += offsets[v];
    index_map->point_indices.resize(offsets.back());
    // Fill using the (already final) offsets as cursors, then restore them.
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t o = index_map->voxel_of_point[i];
        if (o == VoxelIndexMap::kNoVoxel) continue;
        index_map->point_indices[offsets[o]++] = static_cast<std::uint32_t>(i);
    }
    for (std::size_t v = num_output; v > 0; --v) offsets[v] = offsets[v - 1];
    offsets[0] = 0;
}

PointCloud voxel_downsample(const std::vector<Eigen::Vector3d>& points,
                            const VoxelGridParams& params) {
    VoxelGrid grid;
    PointCloud out;
    grid.downsample(points, params, &out);
    return out;
}

}  // namespace lidarfuse::core
