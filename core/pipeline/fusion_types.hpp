#pragma once
// Inputs, outputs and parameters of the FusionEngine (core/pipeline/fusion_engine.hpp).
// Frames: every input scan is in its own sensor frame; every output pose is T_root_sensor,
// root = the root sensor at its first frame (the fused frame). Units: metres, seconds.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/background_model.hpp"
#include "core/gicp.hpp"
#include "core/initial_registration.hpp"
#include "core/preprocess.hpp"

namespace lidarfuse::core {

class InitialRegistrationJob;  // core/pipeline/initial_registration_job.hpp

// One sensor's scan in one synchronised frame.
struct SensorScanInput {
    bool present = false;
    std::int64_t t_ns = 0;  // the scan's timestamp: the instant its pose refers to
    std::vector<Eigen::Vector3d> points;  // sensor frame (m); no-return pixels removed
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
    int covariance_neighbors = 10;
    // G-ICP per edge; max correspondence distance = this factor * voxel_size_m.
    GicpParams gicp{};
    double correspondence_factor = 1.5;
    // Huber delta of the pose graph in sigmas (edge information is calibrated, see engine).
    double huber_delta = 3.0;
    // Per-column motion compensation from the frame-to-frame velocity. Off by default: on
    // simulated 20 Hz captures the velocity estimate and the registration fed each other
    // (a skewed cloud biases the pose, which biases the next velocity) until the root
    // drifted metres; the velocity model needs damping and bounds before it can be on.
    bool deskew = false;
    bool remove_dynamic = true;
    BackgroundModelParams background{};
    InitialRegistrationParams initial = default_initial_registration_params();
    // Where the initial registration (~1 s) runs. false (real time): process() hands it out
    // as FrameOutput::initial_job and keeps fusing the sensors it already tracks; the caller
    // must run the job (any thread) and keep calling process(), which applies the result once
    // the job is done. The root starts tracking on its first frame at once. The job uses
    // `initial_threads` OpenMP threads, so that it leaves the fusion thread a core.
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
    kUninitialised,   // no pose yet (waiting for the initial registration)
    kTracking,        // continuous registration
    kMissing,         // no scan in this frame: pose predicted, not measured
    kReinitialised,   // registered again from scratch in this frame
};

const char* to_string(TrackState state);

struct SensorHealth {
    TrackState state = TrackState::kUninitialised;
    bool included = false;    // the frame held a scan of this sensor
    bool pose_valid = false;  // T_root_sensor is an estimate (else identity, never invented)
    std::size_t points_in = 0, static_points = 0, dynamic_points = 0, registration_points = 0;
    double fitness_previous = 0.0;  // G-ICP inlier share against the previous frame
    double fitness_reference = 0.0; // ... against the reference (first) frame
    std::size_t inliers_reference = 0;
    double min_hessian_eigenvalue = 0.0;  // of the reference edge (conditioning)
    double max_edge_residual_sigma = 0.0; // worst whitened edge residual after optimisation
    std::string event;  // non-empty when something happened (reinitialised, failed, ...)
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
    double preprocess_ms = 0.0;  // deskew, range crop, background model, voxel grid, covariances
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
    // Non-null when this frame started an initial registration that the caller must run
    // (see FusionParams::initial_registration_inline). The engine keeps its own reference.
    std::shared_ptr<InitialRegistrationJob> initial_job;
    bool initial_registration_pending = false;  // a job is out and not applied yet
};

}  // namespace lidarfuse::core
