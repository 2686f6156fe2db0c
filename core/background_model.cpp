#include "core/background_model.hpp"

#include <algorithm>
#include <cmath>

namespace lidarfuse::core {

BackgroundModel::BackgroundModel(const BackgroundModelParams& params)
    : params_(params), detector_(params.change) {
    if (!(params_.voxel_size_m > 0)) params_.voxel_size_m = 0.5;
    voxels_.reserve(1 << 14);
}

void BackgroundModel::set_reference(const std::vector<Eigen::Vector3d>& reference_points) {
    reference_points_ = reference_points;
    detector_.set_reference(reference_points_);
    voxels_.clear();
}

// 21 bits per axis around the origin: +-1048576 voxels, far beyond any LiDAR range.
std::uint64_t BackgroundModel::key_of(const Eigen::Vector3d& p) const {
    const auto q = [this](double v) {
        const double c = std::clamp(std::floor(v / params_.voxel_size_m), -1048576.0, 1048575.0);
        return static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + 1048576) & 0x1FFFFF;
    };
    return (q(p.x()) << 42) | (q(p.y()) << 21) | q(p.z());
}

double BackgroundModel::score_of(std::uint64_t key) const {
    const auto it = voxels_.find(key);
    if (it == voxels_.end()) return 0.0;
    return it->second.score * std::pow(params_.attenuation, static_cast<double>(frame_ - it->second.frame));
}

double BackgroundModel::score_at(const Eigen::Vector3d& p) const {
    return std::isfinite(p.squaredNorm()) ? score_of(key_of(p)) : 0.0;
}

// Raises a voxel once per frame, however many of its points changed.
void BackgroundModel::raise(const Eigen::Vector3d& p) {
    if (!std::isfinite(p.squaredNorm())) return;
    Voxel& v = voxels_[key_of(p)];
    if (v.frame == frame_ && v.score > 0) return;
    const double current = v.score * std::pow(params_.attenuation, static_cast<double>(frame_ - v.frame));
    v.score = std::min(params_.max_score, current + params_.increment);
    v.frame = frame_;
}

void BackgroundModel::update(const std::vector<Eigen::Vector3d>& current, BackgroundUpdate* out) {
    ++frame_;
    detector_.detect(current, &changes_);
    for (std::size_t i = 0; i < current.size(); ++i) {
        if (changes_.added[i]) raise(current[i]);
    }
    for (std::size_t j = 0; j < reference_points_.size(); ++j) {
        if (changes_.removed[j]) raise(reference_points_[j]);
    }

    out->dynamic.assign(current.size(), 0);
    out->num_dynamic = 0;
    for (std::size_t i = 0; i < current.size(); ++i) {
        const bool dyn = changes_.added[i] || score_at(current[i]) > params_.dynamic_threshold;
        out->dynamic[i] = dyn;
        out->num_dynamic += dyn;
    }
    out->reference_dynamic.assign(reference_points_.size(), 0);
    out->num_reference_dynamic = 0;
    for (std::size_t j = 0; j < reference_points_.size(); ++j) {
        const bool dyn =
            changes_.removed[j] || score_at(reference_points_[j]) > params_.dynamic_threshold;
        out->reference_dynamic[j] = dyn;
        out->num_reference_dynamic += dyn;
    }
}

}  // namespace lidarfuse::core
