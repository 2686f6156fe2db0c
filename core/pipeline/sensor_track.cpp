#include "core/pipeline/sensor_track.hpp"

#include <algorithm>
#include <cmath>

#include "core/common/angles.hpp"
#include "core/preprocess/deskew.hpp"
#include "core/preprocess/normals.hpp"

namespace lidarfuse::core {

namespace {
constexpr double kNsToS = 1e-9;

// The points not flagged dynamic (a flag past the end of `dynamic` counts as static),
// mapped by T_grid_sensor into the frame of the voxel grid (null: kept in the sensor frame),
// in one pass. See FusionParams::voxel_grid_in_root_frame.
void static_points_in_grid(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<std::uint8_t>& dynamic,
                           const Eigen::Isometry3d* T_grid_sensor,
                           std::vector<Eigen::Vector3d>* out) {
    out->resize(points.size());
    std::size_t kept = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (i < dynamic.size() && dynamic[i]) continue;
        (*out)[kept++] = T_grid_sensor ? *T_grid_sensor * points[i] : points[i];
    }
    out->resize(kept);
}

// Voxel-grid downsampling of `points_in_grid` (from static_points_in_grid), centroids
// returned in the sensor frame, in Morton order. `twins` as VoxelGrid::downsample.
void downsample_in_grid(VoxelGrid* grid, const std::vector<Eigen::Vector3d>& points_in_grid,
                        double voxel_size_m, const Eigen::Isometry3d* T_grid_sensor,
                        PointCloud* cloud, std::vector<std::uint32_t>* twins = nullptr) {
    VoxelGridParams voxel;
    voxel.voxel_size_m = voxel_size_m;
    // Registration reads a cloud's neighbors together (the k-NN of the covariances, G-ICP's
    // correspondences): in space order they share cache lines (bench/BENCHMARK.md).
    voxel.spatial_order = true;
    grid->downsample(points_in_grid, voxel, cloud, nullptr, twins);
    if (T_grid_sensor) {
        const Eigen::Isometry3d T_sensor_grid = T_grid_sensor->inverse();
        for (auto& p : cloud->points) p = T_sensor_grid * p;
    }
}

// Slower than the deskew limits: faster is a registration glitch or a knock, not sway to undo.
bool within_sway_limits(const Vector6d& twist, const FusionParams& params) {
    return twist.head<3>().norm() <= params.deskew_max_rate_deg_s * kPi / 180.0 &&
           twist.tail<3>().norm() <= params.deskew_max_speed_m_s;
}

double mean_of(const std::vector<float>& values) {
    double sum = 0;
    for (float v : values) sum += v;
    return values.empty() ? 0.0 : sum / static_cast<double>(values.size());
}
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
    return last.T_root_sensor *
           se3_exp(body_twist_per_s(before.T_root_sensor, last.T_root_sensor, dt) * ahead);
}

std::optional<Vector6d> SensorTrack::recent_twist() const {
    if (history_.size() < 3) return std::nullopt;
    const PoseSample& a = history_[history_.size() - 3];
    const PoseSample& b = history_.back();
    const double span_s = static_cast<double>(b.t_ns - a.t_ns) * kNsToS;
    if (!(span_s > 0) || span_s > params_.deskew_max_span_s) return std::nullopt;
    return body_twist_per_s(a.T_root_sensor, b.T_root_sensor, span_s);
}

bool SensorTrack::in_prediction_window(std::int64_t older_ns, std::int64_t newer_ns) const {
    return static_cast<double>(newer_ns - older_ns) * kNsToS <= params_.prediction_window_s;
}

std::optional<Eigen::Isometry3d> SensorTrack::fitted_pose(std::int64_t t_ns) const {
    // finish_frame() keeps the poses within the window, and the last three if fewer: every
    // pose of the history is in the fit, if the oldest is in the window.
    if (static_cast<int>(history_.size()) < std::max(3, params_.prediction_min_poses) ||
        !in_prediction_window(history_.front().t_ns, history_.back().t_ns))
        return std::nullopt;
    const double ahead_s = static_cast<double>(t_ns - history_.back().t_ns) * kNsToS;
    if (ahead_s < 0 || ahead_s > params_.prediction_max_ahead_s) return std::nullopt;
    return extrapolate_pose(history_, t_ns, 2);
}

std::optional<Eigen::Isometry3d> SensorTrack::predict_unregistered(std::int64_t t_ns) const {
    if (prediction_misses_.empty()) return std::nullopt;
    double trans2 = 0, rot2 = 0;
    for (const auto& [t, r] : prediction_misses_) {
        trans2 += t * t;
        rot2 += r * r;
    }
    const double count = static_cast<double>(prediction_misses_.size());
    if (std::sqrt(trans2 / count) > params_.prediction_max_error_m ||
        std::sqrt(rot2 / count) > params_.prediction_max_error_deg)
        return std::nullopt;
    return fitted_pose(t_ns);
}

void SensorTrack::check_prediction(std::int64_t t_ns, const Eigen::Isometry3d& T_root_sensor) {
    const std::optional<Eigen::Isometry3d> fitted = fitted_pose(t_ns);
    // No fit within reach (too few poses, or registered frames further apart than a
    // prediction may reach): the earlier checks say nothing about the poses to come.
    if (!fitted) {
        prediction_misses_.clear();
        return;
    }
    const Eigen::Isometry3d miss = fitted->inverse() * T_root_sensor;
    if (prediction_misses_.size() == kPredictionChecks)
        prediction_misses_.erase(prediction_misses_.begin());
    prediction_misses_.emplace_back(miss.translation().norm(),
                                    rotation_angle_deg(Eigen::Matrix3d::Identity(), miss.linear()));
}

Vector6d SensorTrack::deskew_twist() const {
    if (!params_.deskew) return Vector6d::Zero();
    const std::optional<Vector6d> twist = recent_twist();
    return twist && within_sway_limits(*twist, params_) ? *twist : Vector6d::Zero();
}

std::optional<Eigen::Isometry3d> SensorTrack::deskew_reference(std::int64_t frame) {
    if (!params_.deskew || reference_deskewed_ || !initialised_) return std::nullopt;
    if (frame < reference_frame_ + params_.deskew_reference_after_frames) return std::nullopt;
    reference_deskewed_ = true;
    if (history_.size() < 2 || history_.front().frame != reference_frame_) return std::nullopt;
    const PoseSample& a = history_[0];
    const PoseSample& b = history_[1];
    const double dt_s = static_cast<double>(b.t_ns - a.t_ns) * kNsToS;
    if (!(dt_s > 0) || dt_s > params_.deskew_max_span_s) return std::nullopt;
    const Vector6d twist = body_twist_per_s(a.T_root_sensor, b.T_root_sensor, dt_s);
    if (!within_sway_limits(twist, params_) ||
        reference_point_dt_s_.size() != reference_points_.size() || reference_points_.empty()) {
        return std::nullopt;
    }
    // No point times: nothing to undo.
    if (std::none_of(reference_point_dt_s_.begin(), reference_point_dt_s_.end(),
                     [](float t) { return std::abs(t) > 0.0f; })) {
        return std::nullopt;
    }
    deskew_points(twist, reference_point_dt_s_, &reference_points_);
    rebuild_reference_target();
    return se3_exp(-twist * mean_of(reference_point_dt_s_));
}

double SensorTrack::reference_voxel_size_m() const {
    const double fine = params_.reference_target_voxel_size_m;
    return fine > 0 ? std::min(fine, params_.voxel_size_m) : params_.voxel_size_m;
}

GicpCloud SensorTrack::reference_target_at(double voxel_size_m) const {
    const Eigen::Isometry3d* T_grid =
        params_.voxel_grid_in_root_frame ? &T_root_reference_ : nullptr;
    std::vector<Eigen::Vector3d> points;
    static_points_in_grid(reference_points_, background_update_.reference_dynamic, T_grid, &points);
    PointCloud cloud;
    VoxelGrid grid;
    downsample_in_grid(&grid, points, voxel_size_m, T_grid, &cloud);
    if (cloud.size() < 3) return GicpCloud();
    NormalParams normals;
    normals.k_neighbors = covariance_neighbors_for(params_, voxel_size_m);
    normals.compute_normals = false;
    return GicpCloud(std::move(cloud), normals);
}

void SensorTrack::reanchor(const Eigen::Isometry3d& left,
                           const Eigen::Isometry3d& right_reference) {
    const Eigen::Isometry3d right = se3_exp(-deskew_twist() * mean_of(reference_point_dt_s_));
    T_root_reference_ = orthonormalized(left * T_root_reference_ * right_reference);
    reference_target_current_ = false;
    for (auto& sample : history_) {
        sample.T_root_sensor =
            orthonormalized(left * sample.T_root_sensor *
                            (sample.frame == reference_frame_ ? right_reference : right));
    }
}

void SensorTrack::crop_and_deskew(const SensorScanInput& scan, const Vector6d& twist_per_s) {
    const std::size_t n = scan.points.size();
    const bool have_dt = scan.point_dt_s.size() == n;
    const bool have_intensity = scan.intensity.size() == n;
    const double min2 = params_.range.min_range_m * params_.range.min_range_m;
    const double max2 = params_.range.max_range_m * params_.range.max_range_m;
    // Sized for every point and cut to the kept ones after: no capacity check per point.
    points_.resize(n);
    point_dt_s_.resize(n);
    intensity_.resize(n);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d p = scan.points[i].cast<double>();
        const double r2 = p.squaredNorm();
        if (!std::isfinite(r2) || r2 < min2 || r2 > max2) continue;
        points_[kept] = p;
        point_dt_s_[kept] = have_dt ? scan.point_dt_s[i] : 0.0f;
        intensity_[kept] = have_intensity ? scan.intensity[i] : 0.0f;
        ++kept;
    }
    points_.resize(kept);
    point_dt_s_.resize(kept);
    intensity_.resize(kept);
    if (params_.deskew && have_dt) deskew_points(twist_per_s, point_dt_s_, &points_);
}

void SensorTrack::build_current_target(bool static_only, const Eigen::Isometry3d& T_root_sensor,
                                       TrackScratch* scratch) {
    const Eigen::Isometry3d* T_grid = params_.voxel_grid_in_root_frame ? &T_root_sensor : nullptr;
    static const std::vector<std::uint8_t> kAllStatic;
    std::vector<Eigen::Vector3d>& static_points = scratch->static_points;
    static_points_in_grid(points_, static_only ? dynamic_ : kAllStatic, T_grid, &static_points);
    PointCloud cloud;
    downsample_in_grid(&voxel_grid_, static_points, params_.voxel_size_m, T_grid, &cloud, &twins_);
    make_guesses();
    if (cloud.size() < 3) {
        current_target_ = GicpCloud(std::move(cloud));
        return;
    }
    NormalParams normals;
    normals.k_neighbors = covariance_neighbors_for(params_, params_.voxel_size_m);
    normals.compute_normals = false;
    current_target_ = GicpCloud(std::move(cloud), normals);  // one thread: tracks run in parallel
}

void SensorTrack::start(std::int64_t frame, const SensorScanInput& scan,
                        const Eigen::Isometry3d& T_root_sensor, TrackScratch* scratch) {
    initialised_ = true;
    reference_frame_ = frame;
    T_root_reference_ = T_root_sensor;
    history_.clear();
    prediction_misses_.clear();
    crop_and_deskew(scan, Vector6d::Zero());
    dynamic_.assign(points_.size(), 0);
    dynamic_count_ = 0;
    background_.set_reference(points_, &scratch->background);
    // The last update's flags index the previous reference's points (a restarted track).
    background_update_ = BackgroundUpdate{};
    reference_points_ = points_;
    reference_point_dt_s_ = point_dt_s_;
    reference_deskewed_ = false;
    reference_dynamic_at_build_ = 0;
    previous_in_reference_.clear();
    build_current_target(false, T_root_sensor, scratch);
    // The reference target is a copy of the first frame's cloud (the current one moves on).
    if (reference_voxel_size_m() == params_.voxel_size_m) {
        reference_target_ = current_target_.clone();
        reference_target_current_ = false;  // built by another path
    } else {
        reference_target_ = reference_target_at(reference_voxel_size_m());
        reference_target_current_ = true;
    }
}

void SensorTrack::reset() {
    initialised_ = false;
    history_.clear();
    prediction_misses_.clear();
    reference_target_ = GicpCloud();
    reference_target_current_ = false;
    previous_target_ = GicpCloud();
    current_target_ = GicpCloud();
    T_root_reference_ = Eigen::Isometry3d::Identity();
}

void SensorTrack::rebuild_reference_target() {
    GicpCloud target = reference_target_at(reference_voxel_size_m());
    if (target.size() < 3) {
        reference_target_current_ = false;  // the old target is kept rather than none
        return;
    }
    reference_target_ = std::move(target);
    reference_target_current_ = true;
    previous_in_reference_.clear();  // indices into the old target
    reference_dynamic_at_build_ = background_update_.num_reference_dynamic;
}

void SensorTrack::make_guesses() {
    previous_guess_.clear();
    reference_guess_.clear();
    current_in_reference_.clear();
    const std::size_t previous_size = previous_target_.size();
    const bool in_reference = previous_in_reference_.size() == previous_size && previous_size > 0;
    if (previous_size == 0) return;
    previous_guess_.reserve(twins_.size());
    for (const std::uint32_t twin : twins_) {
        const bool known = twin < previous_size;
        previous_guess_.push_back(known ? static_cast<std::int32_t>(twin) : -1);
        if (in_reference) reference_guess_.push_back(known ? previous_in_reference_[twin] : -1);
    }
}

void SensorTrack::set_reference_correspondences(const std::vector<std::int32_t>& correspondences) {
    if (correspondences.size() == current_target_.size()) current_in_reference_ = correspondences;
}

void SensorTrack::prepare(const SensorScanInput& scan, const Eigen::Isometry3d& T_root_predicted,
                          TrackScratch* scratch) {
    prepare_points(scan, T_root_predicted, scratch);
    build_current_target(params_.remove_dynamic, T_root_predicted, scratch);
}

void SensorTrack::prepare_points(const SensorScanInput& scan,
                                 const Eigen::Isometry3d& T_root_predicted, TrackScratch* scratch) {
    crop_and_deskew(scan, deskew_twist());
    dynamic_.assign(points_.size(), 0);
    dynamic_count_ = 0;
    if (params_.remove_dynamic && background_.has_reference()) {
        const Eigen::Isometry3d T_reference_current =
            T_root_reference_.inverse() * T_root_predicted;
        std::vector<Eigen::Vector3d>& in_reference_frame = scratch->in_reference_frame;
        in_reference_frame.resize(points_.size());
        for (std::size_t i = 0; i < points_.size(); ++i)
            in_reference_frame[i] = T_reference_current * points_[i];
        background_.update(in_reference_frame, &background_update_, &scratch->background);
        reference_target_current_ = false;  // the reference points' flags may have changed
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
}

void SensorTrack::finish_frame(std::int64_t frame, std::int64_t t_ns,
                               const Eigen::Isometry3d& T_root_sensor) {
    // A clock stepped back (the station's time source corrected, a capture replayed in a
    // loop): the poses kept are on another time line, and a fit or a twist through both
    // means nothing. Kept, they would stay "within the window" (their distance to the new
    // stamps is negative) until the new clock passed them, and no prediction could be
    // trusted all that time.
    if (!history_.empty() && t_ns <= history_.back().t_ns) {
        history_.clear();
        prediction_misses_.clear();
    }
    check_prediction(t_ns, T_root_sensor);
    history_.push_back({frame, t_ns, T_root_sensor});
    std::size_t drop = 0;
    while (history_.size() - drop > 3 && !in_prediction_window(history_[drop].t_ns, t_ns)) ++drop;
    history_.erase(history_.begin(), history_.begin() + static_cast<std::ptrdiff_t>(drop));
    previous_target_ = std::move(current_target_);
    current_target_ = GicpCloud();
    previous_in_reference_ = std::move(current_in_reference_);
    current_in_reference_.clear();
}

}  // namespace lidarfuse::core
