#include "core/pipeline/sensor_track.hpp"

#include "core/deskew.hpp"
#include "core/normals.hpp"

namespace lidarfuse::core {

namespace {
constexpr double kNsToS = 1e-9;
}  // namespace

SensorTrack::SensorTrack(const FusionParams& params)
    : params_(params), background_(params.background) {}

std::optional<PoseSample> SensorTrack::previous() const {
    if (history_.empty()) return std::nullopt;
    return history_.back();
}

Eigen::Isometry3d SensorTrack::predict(std::int64_t t_ns) const {
    if (history_.empty()) return T_root_reference_;
    const PoseSample& last = history_.back();
    if (history_.size() < 2) return last.T_root_sensor;
    const PoseSample& before = history_[history_.size() - 2];
    const double dt = static_cast<double>(last.t_ns - before.t_ns) * kNsToS;
    const double ahead = static_cast<double>(t_ns - last.t_ns) * kNsToS;
    // A long gap (sensor silent) makes the velocity meaningless: hold the last pose.
    if (!(dt > 0) || ahead < 0 || ahead > 1.0) return last.T_root_sensor;
    return last.T_root_sensor * se3_exp(body_twist_per_s(before.T_root_sensor, last.T_root_sensor, dt) * ahead);
}

void SensorTrack::crop_and_deskew(const SensorScanInput& scan, const Vector6d& twist_per_s) {
    points_.clear();
    point_dt_s_.clear();
    intensity_.clear();
    const bool have_dt = scan.point_dt_s.size() == scan.points.size();
    const bool have_intensity = scan.intensity.size() == scan.points.size();
    const double min2 = params_.range.min_range_m * params_.range.min_range_m;
    const double max2 = params_.range.max_range_m * params_.range.max_range_m;
    for (std::size_t i = 0; i < scan.points.size(); ++i) {
        const Eigen::Vector3d& p = scan.points[i];
        const double r2 = p.squaredNorm();
        if (!std::isfinite(r2) || r2 < min2 || r2 > max2) continue;
        points_.push_back(p);
        point_dt_s_.push_back(have_dt ? scan.point_dt_s[i] : 0.0f);
        intensity_.push_back(have_intensity ? scan.intensity[i] : 0.0f);
    }
    if (params_.deskew && have_dt) deskew_points(twist_per_s, point_dt_s_, &points_);
}

void SensorTrack::build_current_target(bool static_only) {
    static_points_.clear();
    for (std::size_t i = 0; i < points_.size(); ++i) {
        if (!static_only || !dynamic_[i]) static_points_.push_back(points_[i]);
    }
    PointCloud cloud;
    VoxelGridParams voxel;
    voxel.voxel_size_m = params_.voxel_size_m;
    voxel_grid_.downsample(static_points_, voxel, &cloud);
    if (cloud.size() >= 3) {
        NormalParams normals;
        normals.k_neighbors = params_.covariance_neighbors;
        normals.compute_normals = false;
        normals.num_threads = 1;  // tracks already run in parallel
        estimate_normals_covariances(&cloud, normals);
    }
    current_target_ = GicpTarget(std::move(cloud));
}

void SensorTrack::start(std::int64_t frame, const SensorScanInput& scan,
                        const Eigen::Isometry3d& T_root_sensor) {
    initialised_ = true;
    reference_frame_ = frame;
    T_root_reference_ = T_root_sensor;
    history_.clear();
    crop_and_deskew(scan, Vector6d::Zero());
    dynamic_.assign(points_.size(), 0);
    dynamic_count_ = 0;
    background_.set_reference(points_);
    reference_points_ = points_;
    reference_dynamic_at_build_ = 0;
    build_current_target(false);
    // The reference target is a copy of the first frame's cloud (the current one moves on).
    reference_target_ = GicpTarget(current_target_.cloud());
}

void SensorTrack::reset() {
    initialised_ = false;
    history_.clear();
    reference_target_ = GicpTarget();
    previous_target_ = GicpTarget();
    current_target_ = GicpTarget();
    T_root_reference_ = Eigen::Isometry3d::Identity();
}

void SensorTrack::rebuild_reference_target() {
    static_points_.clear();
    const auto& flags = background_update_.reference_dynamic;
    for (std::size_t j = 0; j < reference_points_.size(); ++j) {
        if (j >= flags.size() || !flags[j]) static_points_.push_back(reference_points_[j]);
    }
    PointCloud cloud;
    VoxelGridParams voxel;
    voxel.voxel_size_m = params_.voxel_size_m;
    voxel_grid_.downsample(static_points_, voxel, &cloud);
    if (cloud.size() < 3) return;  // keep the old target rather than none
    NormalParams normals;
    normals.k_neighbors = params_.covariance_neighbors;
    normals.compute_normals = false;
    normals.num_threads = 1;
    estimate_normals_covariances(&cloud, normals);
    reference_target_ = GicpTarget(std::move(cloud));
    reference_dynamic_at_build_ = background_update_.num_reference_dynamic;
}

void SensorTrack::prepare(const SensorScanInput& scan, const Eigen::Isometry3d& T_root_predicted) {
    Vector6d twist = Vector6d::Zero();
    if (history_.size() >= 2) {
        const PoseSample& a = history_[history_.size() - 2];
        const PoseSample& b = history_.back();
        twist = body_twist_per_s(a.T_root_sensor, b.T_root_sensor,
                                 static_cast<double>(b.t_ns - a.t_ns) * kNsToS);
    }
    crop_and_deskew(scan, twist);
    dynamic_.assign(points_.size(), 0);
    dynamic_count_ = 0;
    if (params_.remove_dynamic && background_.has_reference()) {
        const Eigen::Isometry3d T_reference_current = T_root_reference_.inverse() * T_root_predicted;
        in_reference_frame_.resize(points_.size());
        for (std::size_t i = 0; i < points_.size(); ++i) in_reference_frame_[i] = T_reference_current * points_[i];
        background_.update(in_reference_frame_, &background_update_);
        dynamic_ = background_update_.dynamic;
        dynamic_count_ = background_update_.num_dynamic;
        // Vehicles of the first frame that have left: drop them from the reference target
        // once they are a noticeable share (rebuilding costs a voxel grid and a k-d tree).
        const std::size_t flagged = background_update_.num_reference_dynamic;
        const std::size_t changed = flagged > reference_dynamic_at_build_
                                        ? flagged - reference_dynamic_at_build_
                                        : reference_dynamic_at_build_ - flagged;
        if (changed > reference_points_.size() / 100 + 50) rebuild_reference_target();
    }
    build_current_target(params_.remove_dynamic);
}

void SensorTrack::finish_frame(std::int64_t frame, std::int64_t t_ns,
                               const Eigen::Isometry3d& T_root_sensor) {
    history_.push_back({frame, t_ns, T_root_sensor});
    while (history_.size() > 3) history_.pop_front();
    previous_target_ = std::move(current_target_);
    current_target_ = GicpTarget();
}

}  // namespace lidarfuse::core
