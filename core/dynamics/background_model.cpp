#include "core/dynamics/background_model.hpp"

#include <algorithm>
#include <cmath>

namespace lidarfuse::core {

namespace {
constexpr std::uint64_t kNoKey = ~std::uint64_t{0};  // a point that is not finite
constexpr std::size_t kPowers = 256;                 // attenuation^k tabulated below this k
constexpr int kHotSlotBits = 16;                     // 65,536 slots, 8 KiB
std::size_t hot_slot(std::uint64_t key) {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - kHotSlotBits));
}
}  // namespace

BackgroundModel::BackgroundModel(const BackgroundModelParams& params)
    : params_(params), detector_(params.change) {
    if (!(params_.voxel_size_m > 0)) params_.voxel_size_m = 0.5;
    // A power of two's inverse is exact, and then v * (1 / size) is v / size to the bit.
    int exponent = 0;
    if (std::frexp(params_.voxel_size_m, &exponent) == 0.5)
        inverse_voxel_size_ = 1.0 / params_.voxel_size_m;
    voxels_.reserve(1 << 14);
    index_.reserve(1 << 14);
    // The same values std::pow gives, looked up instead of recomputed per point.
    for (std::size_t k = 0; k < kPowers; ++k) {
        attenuation_powers_.push_back(std::pow(params_.attenuation, static_cast<double>(k)));
    }
    hot_slots_.assign((std::size_t{1} << kHotSlotBits) / 64, 0);
    forget_after_frames_ = ~std::uint64_t{0};
    const double a = params_.attenuation;
    if (a > 0 && a < 1 && params_.max_score > 0) {
        forget_after_frames_ = static_cast<std::uint64_t>(
            std::ceil(std::log(1e-12 / params_.max_score) / std::log(a)));
    } else if (a <= 0) {
        forget_after_frames_ = 1;
    }
}

BackgroundScratch* BackgroundModel::own_scratch() {
    if (!own_scratch_) own_scratch_ = std::make_unique<BackgroundScratch>();
    return own_scratch_.get();
}

void BackgroundModel::set_reference(const std::vector<Eigen::Vector3d>& reference_points) {
    set_reference(reference_points, own_scratch());
}

void BackgroundModel::set_reference(const std::vector<Eigen::Vector3d>& reference_points,
                                    BackgroundScratch* scratch) {
    num_reference_ = reference_points.size();
    reference_keys_.resize(num_reference_);
    for (std::size_t j = 0; j < num_reference_; ++j) {
        const auto& p = reference_points[j];
        reference_keys_[j] = std::isfinite(p.squaredNorm()) ? key_of(p) : kNoKey;
    }
    detector_.set_reference(reference_points, &scratch->detection);
    voxels_.clear();
    index_.clear();
}

// 21 bits per axis around the origin: +-1048576 voxels, far beyond any LiDAR range.
std::uint64_t BackgroundModel::key_of(const Eigen::Vector3d& p) const {
    const auto q = [this](double v) {
        const double scaled =
            inverse_voxel_size_ > 0 ? v * inverse_voxel_size_ : v / params_.voxel_size_m;
        const double c = std::clamp(std::floor(scaled), -1048576.0, 1048575.0);
        return static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + 1048576) & 0x1FFFFF;
    };
    return (q(p.x()) << 42) | (q(p.y()) << 21) | q(p.z());
}

double BackgroundModel::attenuation_after(std::uint64_t frames) const {
    return frames < kPowers ? attenuation_powers_[frames]
                            : std::pow(params_.attenuation, static_cast<double>(frames));
}

double BackgroundModel::score_of(std::uint64_t key) const {
    if (key == kNoKey) return 0.0;
    const auto it = index_.find(key);
    if (it == index_.end()) return 0.0;
    const Voxel& v = voxels_[it->second];
    return v.score * attenuation_after(frame_ - v.frame);
}

double BackgroundModel::score_at(const Eigen::Vector3d& p) const {
    return std::isfinite(p.squaredNorm()) ? score_of(key_of(p)) : 0.0;
}

// Raises a voxel once per frame, however many of its points changed.
void BackgroundModel::raise(std::uint64_t key) {
    if (key == kNoKey) return;
    const auto [it, added] = index_.try_emplace(key, static_cast<std::uint32_t>(voxels_.size()));
    if (added) voxels_.push_back(Voxel{key, 0.0, 0});
    Voxel& v = voxels_[it->second];
    if (v.frame == frame_ && v.score > 0) return;
    const double current = v.score * attenuation_after(frame_ - v.frame);
    v.score = std::min(params_.max_score, current + params_.increment);
    v.frame = frame_;
}

void BackgroundModel::mark_hot_voxels() {
    std::fill(hot_slots_.begin(), hot_slots_.end(), 0);
    for (std::size_t i = 0; i < voxels_.size();) {
        const Voxel& v = voxels_[i];
        const std::uint64_t age = frame_ - v.frame;
        if (age > forget_after_frames_) {
            forget(i);  // the last voxel moves to i: look at i again
            continue;
        }
        if (v.score * attenuation_after(age) > params_.dynamic_threshold) {
            const std::size_t slot = hot_slot(v.key);
            hot_slots_[slot >> 6] |= std::uint64_t{1} << (slot & 63);
        }
        ++i;
    }
}

// Voxel i out of the array (the last one takes its place) and out of the index.
void BackgroundModel::forget(std::size_t i) {
    index_.erase(voxels_[i].key);
    if (i + 1 != voxels_.size()) {
        voxels_[i] = voxels_.back();
        index_[voxels_[i].key] = static_cast<std::uint32_t>(i);
    }
    voxels_.pop_back();
}

bool BackgroundModel::maybe_hot(std::uint64_t key) const {
    if (key == kNoKey) return false;
    const std::size_t slot = hot_slot(key);
    return (hot_slots_[slot >> 6] >> (slot & 63)) & 1;
}

void BackgroundModel::update(const std::vector<Eigen::Vector3d>& current, BackgroundUpdate* out) {
    update(current, out, own_scratch());
}

void BackgroundModel::update(const std::vector<Eigen::Vector3d>& current, BackgroundUpdate* out,
                             BackgroundScratch* scratch) {
    ++frame_;
    const ChangeDetectionResult& changes = scratch->changes;
    std::vector<std::uint64_t>& current_keys = scratch->current_keys;
    detector_.detect(current, &scratch->changes, &scratch->detection);
    current_keys.resize(current.size());
    for (std::size_t i = 0; i < current.size(); ++i) {
        const auto& p = current[i];
        current_keys[i] = std::isfinite(p.squaredNorm()) ? key_of(p) : kNoKey;
    }
    for (std::size_t i = 0; i < current.size(); ++i) {
        if (changes.added[i]) raise(current_keys[i]);
    }
    for (std::size_t j = 0; j < num_reference_; ++j) {
        if (changes.removed[j]) raise(reference_keys_[j]);
    }
    mark_hot_voxels();
    // Neighboring points of a scan row mostly share a voxel: the last key's answer is kept.
    std::uint64_t last_key = kNoKey;
    bool last_above = false;
    const auto above_threshold = [&](std::uint64_t key) {
        if (key != last_key) {
            last_above = maybe_hot(key) && score_of(key) > params_.dynamic_threshold;
            last_key = key;
        }
        return last_above;
    };
    out->dynamic.assign(current.size(), 0);
    out->num_dynamic = 0;
    for (std::size_t i = 0; i < current.size(); ++i) {
        const bool dyn = changes.added[i] || above_threshold(current_keys[i]);
        out->dynamic[i] = dyn;
        out->num_dynamic += dyn;
    }
    out->reference_dynamic.assign(num_reference_, 0);
    out->num_reference_dynamic = 0;
    for (std::size_t j = 0; j < num_reference_; ++j) {
        const bool dyn = changes.removed[j] || above_threshold(reference_keys_[j]);
        out->reference_dynamic[j] = dyn;
        out->num_reference_dynamic += dyn;
    }
}

}  // namespace lidarfuse::core
