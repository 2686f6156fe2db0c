#pragma once
// One sensor's state in the continuous registration: its reference (first) frame, the
// previous frame, the background model, the recent poses for prediction and deskew, and
// the current frame prepared for G-ICP. Owned by the FusionEngine; one per sensor.
// Not thread safe; different tracks are independent (the engine prepares them in parallel).

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "core/dynamics/background_model.hpp"
#include "core/pipeline/fusion_types.hpp"
#include "core/pipeline/pose_extrapolation.hpp"
#include "core/preprocess/voxel_grid.hpp"
#include "core/registration/gicp.hpp"

namespace lidarfuse::core {

// What preparing a scan builds and is done with before the next scan: the background
// model's scratch and the current points in the reference frame and without the dynamic
// ones (about 6 MB for an OS1-64). The engine keeps one per thread of its team, shared by
// the tracks that thread prepares one after another, instead of one per sensor.
struct TrackScratch {
    BackgroundScratch background;
    std::vector<Eigen::Vector3d> in_reference_frame;  // current points, reference sensor frame
    std::vector<Eigen::Vector3d> static_points;       // current static points, sensor frame
};

class SensorTrack {
public:
    explicit SensorTrack(const FusionParams& params);

    bool initialised() const { return initialised_; }
    std::int64_t reference_frame() const { return reference_frame_; }

    // (Re)starts tracking: `scan` becomes the reference frame, at pose T_root_sensor.
    // Prepares the scan (no motion known yet: no deskew) and resets the background model.
    // `scratch`: the calling thread's (also for prepare() and prepare_points()).
    void start(std::int64_t frame, const SensorScanInput& scan,
               const Eigen::Isometry3d& T_root_sensor, TrackScratch* scratch);

    // Stops tracking (diverged; waiting for a new initial registration): no pose, no targets.
    void reset();

    // Constant-velocity prediction of the pose at t_ns from the last two poses.
    Eigen::Isometry3d predict(std::int64_t t_ns) const;
    // The pose at t_ns for a frame fused without registration (FrameMode::kPredict): the
    // constant-acceleration fit over the registered poses of the last
    // FusionParams::prediction_window_s (pose_extrapolation.hpp). nullopt where it is not
    // to be trusted: fewer than prediction_min_poses such poses, t_ns before the newest or
    // more than prediction_max_ahead_s after it, or the fit's checks against the last
    // registered poses missing by more than prediction_max_error_m / _deg, as an RMS over
    // the last four checks (none made yet counts as missed).
    std::optional<Eigen::Isometry3d> predict_unregistered(std::int64_t t_ns) const;
    // The body twist (per second) used to deskew the current scan: the mean velocity over
    // the last three poses (two frame periods), clamped. Zero until three poses are known,
    // across gaps longer than FusionParams::deskew_max_span_s, and above the rate bounds.
    // Why two periods: a pose estimated from a scan deskewed with velocity v moves by about
    // -v * T/2; with v from the last two poses that feedback has a pole at -1 (an undamped
    // frame-to-frame oscillation); over two periods its poles lie inside |z| < 0.7.
    Vector6d deskew_twist() const;
    // Reference (first) frame deskew, once its motion is known: the reference scan was taken
    // before any velocity estimate, so it is deskewed later, with the twist from its pose to
    // the next, and the reference target is rebuilt. Returns the right factor that moves the
    // reference pose from the rigid fit of the skewed scan (about its mean point time) to the
    // scan timestamp, exp(-xi * mean dt); nullopt when nothing was done (deskew off, not
    // enough history yet, or already done). Gives up (done, nothing changed) when the pose
    // after the reference frame is unknown: history lost across a gap, or a sensor that
    // started tracking frames after its reference scan (registered on another thread; its
    // free reference node takes up the sweep's rigid part, see fusion_engine_test
    // LateRegisteredSensorsAreAsAccurateAsInline).
    std::optional<Eigen::Isometry3d> deskew_reference(std::int64_t frame);
    bool reference_deskewed() const { return reference_deskewed_; }
    // The reference scan's static points downsampled at `voxel_size_m`, with covariances
    // (for the fine inter-sensor edges between reference frames). Empty if fewer than 3.
    GicpCloud reference_target_at(double voxel_size_m) const;
    // The reference target itself where it is what reference_target_at(voxel_size_m) would
    // build now (built at that voxel size from the present reference points, flags and
    // pose, none of them changed since); otherwise null. Saves building the same cloud twice.
    const GicpCloud* reference_target_if_built_at(double voxel_size_m) const {
        return reference_target_current_ && voxel_size_m == reference_voxel_size_m()
                   ? &reference_target_
                   : nullptr;
    }
    // Voxel size of the reference target (FusionParams::reference_target_voxel_size_m).
    double reference_voxel_size_m() const;
    // After deskew_reference(): maps the reference pose and the pose history to the deskewed
    // meaning, T <- left * T * right (history: right from the current twist).
    void reanchor(const Eigen::Isometry3d& left, const Eigen::Isometry3d& right_reference);

    // Deskews with the current motion estimate, crops, flags dynamic points against the
    // reference (pre-aligned with T_root_predicted), downsamples the static points and
    // computes their covariances. Fills the "current" members below.
    void prepare(const SensorScanInput& scan, const Eigen::Isometry3d& T_root_predicted,
                 TrackScratch* scratch);
    // The first half of prepare(): deskewed, cropped points and their dynamic flags (the
    // background model takes the scan), no G-ICP target. For a frame fused at its predicted
    // pose (FrameMode::kPredict): the current and previous targets stay as they were.
    void prepare_points(const SensorScanInput& scan, const Eigen::Isometry3d& T_root_predicted,
                        TrackScratch* scratch);

    // Records the estimated pose of the current frame and makes it the previous frame.
    void finish_frame(std::int64_t frame, std::int64_t t_ns,
                      const Eigen::Isometry3d& T_root_sensor);
    // The reference pose is refined while its frame is in the window.
    void set_reference_pose(const Eigen::Isometry3d& T_root_reference) {
        // The voxel grid lies in the root frame (FusionParams::voxel_grid_in_root_frame).
        if (T_root_reference.matrix() != T_root_reference_.matrix())
            reference_target_current_ = false;
        T_root_reference_ = T_root_reference;
    }
    const Eigen::Isometry3d& reference_pose() const { return T_root_reference_; }

    // Targets for G-ICP (sensor frames of their own frames). May be empty.
    const GicpCloud& reference_target() const { return reference_target_; }
    const GicpCloud& previous_target() const { return previous_target_; }
    const GicpCloud& current_target() const { return current_target_; }
    std::optional<PoseSample> previous() const;

    // Where each current point's G-ICP correspondence probably is (target indices, -1 for
    // none; empty when there is no guess): in the previous target, the point of the same
    // voxel of the grid; in the reference target, where the previous frame's point of that
    // voxel found its own. The guesses only speed the search up (GicpRegistration::align).
    const std::vector<std::int32_t>& previous_guess() const { return previous_guess_; }
    const std::vector<std::int32_t>& reference_guess() const { return reference_guess_; }
    // The current points' correspondences in the reference target after this frame's
    // alignment, for the next frame's reference guess.
    void set_reference_correspondences(const std::vector<std::int32_t>& correspondences);

    // The prepared current frame: all cropped points (sensor frame, deskewed) with their
    // dynamic flags, for the fused cloud.
    const std::vector<Eigen::Vector3d>& current_points() const { return points_; }
    const std::vector<std::uint8_t>& current_dynamic() const { return dynamic_; }
    const std::vector<float>& current_intensity() const { return intensity_; }
    std::size_t current_dynamic_count() const { return dynamic_count_; }

private:
    // The mean body twist (per second) over the last three poses, when they lie within
    // FusionParams::deskew_max_span_s: what deskew_twist() moves by.
    std::optional<Vector6d> recent_twist() const;
    // Whether a pose at older_ns is within FusionParams::prediction_window_s of newer_ns.
    bool in_prediction_window(std::int64_t older_ns, std::int64_t newer_ns) const;
    // The fit over the history at t_ns, when the history holds enough poses of the window
    // and t_ns is within reach.
    std::optional<Eigen::Isometry3d> fitted_pose(std::int64_t t_ns) const;
    // finish_frame(): the fit against the pose just registered, before it joins the history.
    void check_prediction(std::int64_t t_ns, const Eigen::Isometry3d& T_root_sensor);
    void crop_and_deskew(const SensorScanInput& scan, const Vector6d& twist_per_s);
    // Downsamples on the grid of FusionParams::voxel_grid_in_root_frame, at T_root_sensor.
    void build_current_target(bool static_only, const Eigen::Isometry3d& T_root_sensor,
                              TrackScratch* scratch);
    // Rebuilds the reference target without the reference points the background model
    // found to have left (vehicles present in the first frame).
    void rebuild_reference_target();
    // The guesses for the current points from their voxels' twins (VoxelGrid::downsample).
    void make_guesses();

    const FusionParams& params_;
    bool initialised_ = false;
    std::int64_t reference_frame_ = 0;
    Eigen::Isometry3d T_root_reference_ = Eigen::Isometry3d::Identity();
    GicpCloud reference_target_;
    bool reference_target_current_ = false;  // see reference_target_if_built_at()
    GicpCloud previous_target_;
    GicpCloud current_target_;
    BackgroundModel background_;
    BackgroundUpdate background_update_;
    // Registered poses, oldest first, their stamps strictly increasing (finish_frame clears
    // it when a clock steps back): the last three, and those within
    // FusionParams::prediction_window_s of the newest.
    std::vector<PoseSample> history_;
    // The fit's last checks against registered poses: how far each missed (m, deg). Their
    // RMS, not one check, decides: a single check differs by two poses' registration noise.
    static constexpr std::size_t kPredictionChecks = 4;
    std::vector<std::pair<double, double>> prediction_misses_;
    VoxelGrid voxel_grid_;
    std::vector<std::uint32_t> twins_;  // current point -> previous point of the same voxel
    std::vector<std::int32_t> previous_guess_;
    std::vector<std::int32_t> reference_guess_;
    // Per point of the current / previous target, its correspondence in the reference
    // target (empty when unknown, or the reference target has changed since).
    std::vector<std::int32_t> current_in_reference_;
    std::vector<std::int32_t> previous_in_reference_;

    std::vector<Eigen::Vector3d> points_;
    std::vector<float> point_dt_s_;
    std::vector<float> intensity_;
    std::vector<std::uint8_t> dynamic_;
    std::size_t dynamic_count_ = 0;
    std::vector<Eigen::Vector3d> reference_points_;
    std::vector<float> reference_point_dt_s_;
    bool reference_deskewed_ = false;
    std::size_t reference_dynamic_at_build_ = 0;
};

}  // namespace lidarfuse::core
