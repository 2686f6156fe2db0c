#include "core/pipeline/fused_cloud_voxels.hpp"

#include <limits>

#include "core/preprocess/voxel_grid.hpp"

namespace lidarfuse::core {

namespace {
constexpr std::uint64_t kEmptyKey = std::numeric_limits<std::uint64_t>::max();
constexpr std::uint64_t kDynamicBit = std::uint64_t{1} << 63;  // voxel_key leaves it free
}  // namespace

// Slots for `voxels` voxels at a load factor <= 0.5, the voxels so far placed again.
void FusedCloudVoxels::reserve_slots(std::size_t voxels) {
    std::size_t capacity = 1024;
    int shift_bits = 10;
    while (capacity < 2 * voxels) {
        capacity <<= 1;
        ++shift_bits;
    }
    if (capacity <= slots_.size()) return;
    hash_shift_ = 64 - shift_bits;
    slots_.assign(capacity, Slot{kEmptyKey, 0});
    for (std::size_t v = 0; v < voxel_keys_.size(); ++v)
        slots_[slot_of(voxel_keys_[v])] = {voxel_keys_[v], static_cast<std::uint32_t>(v)};
}

std::size_t FusedCloudVoxels::slot_of(std::uint64_t key) const {
    const std::size_t mask = slots_.size() - 1;
    std::size_t slot = voxel_slot(key, hash_shift_);
    while (slots_[slot].key != key && slots_[slot].key != kEmptyKey) slot = (slot + 1) & mask;
    return slot;
}

std::uint32_t FusedCloudVoxels::voxel_of(std::uint64_t key, std::uint8_t sensor) {
    Slot& recent = recent_[voxel_slot(key, 64 - kRecentBits)];
    if (recent.key == key) return recent.voxel;
    std::size_t slot = slot_of(key);
    if (slots_[slot].key != key) {
        if (2 * (voxel_keys_.size() + 1) > slots_.size()) {
            reserve_slots(voxel_keys_.size() + 1);
            slot = slot_of(key);
        }
        slots_[slot] = {key, add_voxel(key, sensor)};
    }
    recent = slots_[slot];
    return recent.voxel;
}

std::uint32_t FusedCloudVoxels::add_voxel(std::uint64_t key, std::uint8_t sensor) {
    voxel_keys_.push_back(key);
    sums_.push_back(Sums{});
    sensor_.push_back(sensor);
    dynamic_.push_back((key & kDynamicBit) != 0);
    return static_cast<std::uint32_t>(voxel_keys_.size() - 1);
}

void FusedCloudVoxels::downsample(const FusedCloud& in, double voxel_size_m, FusedCloud* out) {
    out->clear();
    const std::size_t expected = voxel_keys_.size();  // the last cloud's: frames are alike
    voxel_keys_.clear();
    sums_.clear();
    sensor_.clear();
    dynamic_.clear();
    const std::size_t n = in.points.size();
    if (n == 0 || !(voxel_size_m > 0.0)) return;
    slots_.clear();
    reserve_slots(expected);
    recent_.assign(std::size_t{1} << kRecentBits, Slot{kEmptyKey, 0});
    const double inv_size = 1.0 / voxel_size_m;
    // Neighboring points of a sensor's scan row mostly share a voxel: the last key's voxel
    // skips the probe.
    std::uint64_t last_key = kEmptyKey;
    std::uint32_t voxel = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d p = in.points[i].cast<double>();
        std::uint64_t key = 0;
        if (!voxel_key(p, inv_size, &key)) continue;
        if (i < in.dynamic.size() && in.dynamic[i]) key |= kDynamicBit;
        if (key != last_key) {
            voxel = voxel_of(key, i < in.sensor.size() ? in.sensor[i] : 0);
            last_key = key;
        }
        Sums& sum = sums_[voxel];
        sum.point += p;
        sum.intensity += i < in.intensity.size() ? in.intensity[i] : 0.0f;
        ++sum.count;
    }
    const std::size_t voxels = sums_.size();
    out->points.resize(voxels);
    out->intensity.resize(voxels);
    for (std::size_t v = 0; v < voxels; ++v) {
        const double count = static_cast<double>(sums_[v].count);
        out->points[v] = (sums_[v].point / count).cast<float>();
        out->intensity[v] = static_cast<float>(sums_[v].intensity / count);
    }
    out->sensor = sensor_;
    out->dynamic = dynamic_;
}

}  // namespace lidarfuse::core
