#pragma once
// Inputs, outputs and parameters of the FusionEngine (core/pipeline/fusion_engine.hpp).
// Frames: every input scan is in its own sensor frame; every output pose is T_root_sensor,
// root = the root sensor at its first frame (the fused frame). Units: metres, seconds.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/dynamics/background_model.hpp"
#include "core/initial/initial_registration.hpp"
#include "core/preprocess/preprocess.hpp"
#include "core/registration/gicp.hpp"

namespace lidarfuse::core {

class InitialRegistrationJob;  // core/pipeline/initial_registration_job.hpp

// One sensor's scan in one synchronised frame.
struct SensorScanInput {
    bool present = false;
    std::int64_t t_ns = 0;  // the scan's timestamp: the instant its pose refers to
    // Sensor frame (m); no-return pixels removed. Single precision, as the sensors deliver
    // and ROS carries them: an OS1's range is in mm, a float resolves 8 um at 120 m. It
    // halves what every scan waiting in a queue holds; the tracks compute in double from
    // the crop on.
    std::vector<Eigen::Vector3f> points;
    // Per point: acquisition time - t_ns (s), for deskew. Empty: no deskew for this scan.
    std::vector<float> point_dt_s;
    std::vector<float> intensity;  // per point, optional (empty: zeros in the fused cloud)
};

struct FrameInput {
    std::vector<SensorScanInput> sensors;  // one slot per configured sensor, in config order
};

struct FusionParams {
    std::size_t root_sensor = 0;
    // Continuous registration (PAPER.md): voxel size is the speed/accuracy knob (1 m or 3 m).
    double voxel_size_m = 1.0;
    int window_frames = 5;  // k_w: nodes of the last k_w frames stay in the pose graph
    RangeFilterParams range{1.0, 120.0, Eigen::Vector3d::Zero()};
    // k of the G-ICP covariances (the point itself included); 0: from each cloud's voxel
    // size v, round(6 / sqrt(v)) clamped to 4..16 (v = 0.5 m: 8, 1 m: 6, 3 m: 4). Too many
    // neighbors describe the street rather than the surface (10 voxels of 3 m span its
    // width), too few a line rather than a plane (bench/BENCHMARK.md, "G-ICP covariance
    // neighbors").
    int covariance_neighbors = 0;
    // G-ICP per edge; max correspondence distance = this factor * voxel_size_m: one voxel,
    // as PAPER.md's r_c. A wider bound also pairs centroids with the samples of nearby
    // surfaces, and those pairs pull every edge the same way (bench/BENCHMARK.md, "The
    // correspondence bound"). lidarfused's config tightens it for a segment's stations
    // (drivers/station/fusion_config.cpp).
    GicpParams gicp{};
    double correspondence_factor = 1.0;
    // Huber delta of the pose graph in sigmas (edge information is calibrated, see engine).
    double huber_delta = 3.0;
    // Levenberg-Marquardt iterations of the pose graph per frame. Warm-started at the
    // predicted poses, the robust window problem can take many iterations to meet the
    // solver's tolerances, and the poses gain nothing from them (bench/BENCHMARK.md, "Pose
    // graph").
    int graph_max_iterations = 10;
    // Per-column motion compensation (core/preprocess/deskew.hpp): every scan is moved into the
    // sensor frame at its timestamp t_ns (the instant poses refer to) with the body twist of the
    // last three pose estimates (SensorTrack::deskew_twist: two frame periods, which damps
    // the feedback between velocity and registration). Without it a rigid fit of a swaying
    // sensor's sweep lands near its mid-sweep pose, T/2 after t_ns. The reference (first)
    // scan is deskewed once its motion is known, deskew_reference_after_frames later, and
    // the reference poses re-anchored to the scan timestamps (engine). It lowers the
    // rotation error (bench/BENCHMARK.md, "Deskew").
    bool deskew = true;
    double deskew_max_span_s = 0.3;       // poses further apart: no velocity, no deskew
    double deskew_max_rate_deg_s = 30.0;  // faster (a knock, a glitch): no deskew
    double deskew_max_speed_m_s = 3.0;
    int deskew_reference_after_frames = 3;
    // Frames fused at predicted poses (FrameMode::kPredict, for a caller that is behind).
    // A sensor's pose there is a constant-acceleration fit over its registered poses of the
    // last prediction_window_s (at least prediction_min_poses of them), carried at most
    // prediction_max_ahead_s past the newest (pose_extrapolation.hpp). Every registered
    // frame checks the fit: the pose it would have predicted for that frame against the
    // registered one; while the last four checks miss by more than prediction_max_error_m /
    // prediction_max_error_deg RMS (a sway too fast or too jerky for the fit, a glitch) the
    // sensor's frames are registered, not predicted. The bounds are the accuracy the
    // continuous registration is held to at voxel 1 m (2 cm / 0.05 deg): a predicted pose
    // must not be the worst pose published. Figures: bench/BENCHMARK.md, "How far ahead a
    // pose can be predicted".
    double prediction_window_s = 0.4;
    int prediction_min_poses = 4;
    double prediction_max_ahead_s = 0.15;
    double prediction_max_error_m = 0.02;
    double prediction_max_error_deg = 0.05;
    // Fine edges between the reference frames: G-ICP between every pair of the first
    // registration's reference scans at this voxel size (m), once (with deskew: when the
    // references are deskewed, else on the first frame). The relative poses of the reference
    // frames anchor every later pose, and at the tracking voxel size (1 m, 3 m) G-ICP
    // between two viewpoints is biased by how differently their voxel centroids sample the
    // same surfaces. <= 0: off (the reference frames get the tracking-voxel edges only).
    double reference_voxel_size_m = 0.5;
    // The reference (first-frame) target every frame registers against is downsampled at
    // min(this, voxel_size_m): built once (and when vehicles of the first frame leave), so a
    // finer target costs little, while the per-frame sources stay at voxel_size_m. At 3 m a
    // 3 m target's centroids move with the sway relative to the surfaces they stand for
    // (bench/BENCHMARK.md, "Measured behind the defaults"). <= 0: voxel_size_m.
    double reference_target_voxel_size_m = 0.5;
    // Voxel grids fixed in the root frame (points mapped with the predicted pose, centroids
    // mapped back) instead of each sensor's own frame: as a pole sways, a grid that moves
    // with the sensor cuts the same surfaces differently every frame, and at 3 m that
    // resampling moves the centroids -- and the registration -- by centimetres. A common
    // grid also makes two sensors' centroids of a surface they both see comparable.
    bool voxel_grid_in_root_frame = true;
    bool remove_dynamic = true;
    BackgroundModelParams background{};
    InitialRegistrationParams initial = default_initial_registration_params();
    // Where the initial registration (many frame periods long) runs. false (real time):
    // process() hands it out as FrameOutput::initial_job and keeps fusing the sensors it
    // already tracks; the caller must run the job (any thread) and keep calling process(),
    // which applies the result once the job is done. The root starts tracking on its first
    // frame at once. While no other sensor tracks (the first registration, or a retry after
    // all failed) the job uses `num_threads` OpenMP threads, as inline; otherwise
    // `initial_threads`, so that it leaves the fusion thread a core for the sensors it tracks.
    // true (offline, deterministic): process() runs it inline and applies it in the same
    // frame; the result does not depend on timing.
    bool initial_registration_inline = false;
    int initial_threads = 1;
    // Divergence: a sensor whose edge to its reference frame keeps an inlier share below
    // min_fitness, or whose optimised pose jumps by more than max_jump_m / max_jump_deg from
    // the prediction, for divergence_frames frames in a row, is registered again from
    // scratch (initial registration against the root), the others unaffected.
    double min_fitness = 0.3;
    double max_jump_m = 0.5;
    double max_jump_deg = 5.0;
    int divergence_frames = 2;
    // Sensors that failed the initial registration are retried every this many frames.
    int retry_interval_frames = 10;
    // A scan that arrives with fewer valid points than this (lens covered, every return
    // invalid) is treated as missing for that frame: the sensor keeps its predicted pose
    // and is not taken for diverged.
    std::size_t min_scan_points = 100;
    bool build_fused_cloud = true;
    int num_threads = 1;
};

enum class TrackState {
    kUninitialised,  // no pose yet (waiting for the initial registration)
    kTracking,       // continuous registration
    kMissing,        // no scan in this frame: pose predicted, not measured
    kReinitialised,  // registered again from scratch in this frame
    kPredicted,      // scan fused at the pose predicted from the frames registered before
                     // (FrameMode::kPredict: the caller was behind), not registered
};

const char* to_string(TrackState state);

struct SensorHealth {
    TrackState state = TrackState::kUninitialised;
    bool included = false;    // the frame held a scan of this sensor
    bool pose_valid = false;  // T_root_sensor is an estimate (else identity, never invented)
    std::size_t points_in = 0, static_points = 0, dynamic_points = 0, registration_points = 0;
    double fitness_previous = 0.0;   // G-ICP inlier share against the previous frame
    double fitness_reference = 0.0;  // ... against the reference (first) frame
    std::size_t inliers_reference = 0;
    double min_hessian_eigenvalue = 0.0;   // of the reference edge (conditioning)
    double max_edge_residual_sigma = 0.0;  // worst whitened edge residual after optimisation
    std::string event;  // non-empty when something happened (reinitialised, failed, ...)
    // The event is a problem (a scan skipped, a divergence, a refused registration), not
    // normal life (initialised, registration started): logs put it at warning, not info.
    bool event_is_problem = false;
};

// The fused cloud of one frame, in the root frame.
struct FusedCloud {
    std::vector<Eigen::Vector3f> points;
    std::vector<float> intensity;
    std::vector<std::uint8_t> sensor;   // index in the configuration
    std::vector<std::uint8_t> dynamic;  // 1 = flagged by the background model
    void clear() {
        points.clear();
        intensity.clear();
        sensor.clear();
        dynamic.clear();
    }
};

// Wall-clock milliseconds per stage of one frame.
struct FrameTimings {
    double initial_ms = 0.0;
    double preprocess_ms = 0.0;    // deskew, range crop, background model, voxel grid, covariances
    double registration_ms = 0.0;  // G-ICP edges
    double graph_ms = 0.0;
    double fuse_ms = 0.0;
    double total_ms = 0.0;
};

struct FrameOutput {
    std::int64_t frame_index = 0;
    std::vector<Eigen::Isometry3d> T_root_sensor;  // per sensor
    std::vector<std::int64_t> t_ns;                // per sensor: its scan timestamp
    std::vector<SensorHealth> health;
    FusedCloud cloud;
    FrameTimings timings;
    bool graph_usable = false;
    // False: fused at the poses predicted from the frames registered before it
    // (FrameMode::kPredict); no G-ICP edge, no pose-graph solve, and the registration
    // figures of each sensor's health are those of its last registered frame.
    bool registered = true;
    // Non-null when this frame started an initial registration that the caller must run
    // (see FusionParams::initial_registration_inline). The engine keeps its own reference.
    std::shared_ptr<InitialRegistrationJob> initial_job;
    bool initial_registration_pending = false;  // a job is out and not applied yet
    // The initial registration applied in this frame, if any: its result holds every
    // sensor's road plane (SensorRegistration::ground), which core/pipeline/world_frame.hpp turns
    // into a road-aligned frame. Sensor k of the job is order[k] (order[0] is the root); its
    // T_root_sensor there is relative to the root at the job's frame, whose pose in the
    // root frame is T_root0_root (identity for the station's first registration).
    struct AppliedRegistration {
        std::shared_ptr<const InitialRegistrationJob> job;
        std::vector<std::size_t> order;
        Eigen::Isometry3d T_root0_root = Eigen::Isometry3d::Identity();
        bool first = false;  // the station's first registration
    };
    std::optional<AppliedRegistration> applied_registration;
};

// FusionParams::covariance_neighbors for a cloud downsampled at voxel_size_m.
inline int covariance_neighbors_for(const FusionParams& params, double voxel_size_m) {
    if (params.covariance_neighbors > 0) return params.covariance_neighbors;
    const double v = voxel_size_m > 0 ? voxel_size_m : 1.0;
    return std::clamp(static_cast<int>(std::lround(6.0 / std::sqrt(v))), 4, 16);
}

}  // namespace lidarfuse::core
