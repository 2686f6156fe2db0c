#pragma once
// The paper's initial registration (PAPER.md steps 2-9): the extrinsics of n LiDARs from
// one synchronised frame, with no initial guess beyond "not mounted upside down".
//
//   for every sensor:        pre-process -> normals -> octree -> SIFT-3D -> FPFH
//                            (sensor_features.hpp)
//   for every pair i > j:    match -> RANSAC -> Kabsch -> up-vector check -> G-ICP ->
//                            wrong-majority guard scored by the p2p error
//                            (pair_registration.hpp)
//   over all good pairs:     pose graph (Ceres, Huber, information = G-ICP Hessian), root
//                            sensor 0 fixed; sensors that do not overlap the root are
//                            reached through others. Pairs that disagree with the solved
//                            poses by more than the edge tolerances are dropped and the
//                            graph solved again (our addition: a cycle-consistency check).
//                            Before it, a consensus over sampled spanning trees picks one
//                            candidate per pair and refuses sensors whose placement the
//                            data does not decide (edge_consensus.hpp).
//
// Input clouds are in their own sensor frames (sensor at the origin). Output poses are
// T_root_sensor (root = sensor 0). A sensor that cannot be registered gets a reason and no
// pose; the others are unaffected. Deterministic for fixed params (seeded RANSAC; results
// do not depend on the thread count). Threads: `num_threads` OpenMP threads, spread over
// sensors and pairs.

#include <Eigen/Geometry>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/common/point_cloud.hpp"
#include "core/features/sensor_features.hpp"
#include "core/graph/pose_graph.hpp"
#include "core/initial/edge_consensus.hpp"
#include "core/initial/edge_polish.hpp"
#include "core/initial/road_grid_search.hpp"
#include "core/registration/pair_registration.hpp"

namespace lidarfuse::core {

// How the sensors are placed against each other from nothing.
enum class InitialRegistrationMethod {
    kFeatures,  // the paper's: one station's sensors, each in its own sensor frame
    kStations,  // a road segment's stations, each cloud in its road frame
                // (station_registration.hpp)
};

// Ours (issue 20): the stations' initial registration (station_registration.hpp).
struct StationRegistrationParams {
    RoadGridSearchParams search{};
    double gicp_voxel_m = 0.5;  // the G-ICP clouds' voxel
    int covariance_neighbors = 10;
    // One G-ICP run per bound (m), each from the previous result.
    std::vector<double> gicp_max_correspondence_m{1.5, 0.5};
    // G-ICP may move the grid's placement this far (m at the source origin, deg): about two
    // fine cells and a few fine yaw steps, which is how far the grid's best can be from the
    // optimum; farther, G-ICP left for another basin. And it must keep this many inliers
    // (G-ICP voxels, about 250 m^2 of shared surface at 0.5 m): the placements measured
    // kept 2,183-10,264 where right, 581 where 3 m off (bench/BENCHMARK.md, "The stations
    // placed on the road's grid"). Otherwise the pair is refused.
    double max_refinement_move_m = 1.0;
    double max_refinement_move_deg = 1.0;
    std::size_t min_inliers = 1000;
};

struct InitialRegistrationParams {
    InitialRegistrationMethod method = InitialRegistrationMethod::kFeatures;
    StationRegistrationParams stations{};
    SensorFeatureParams features{};
    PairRegistrationParams pair{};
    PoseGraphParams pose_graph{};
    std::size_t min_keypoints = 8;
    // Cycle check: an edge whose measurement disagrees with the optimised poses by more
    // than this is dropped (m, deg).
    double max_edge_translation_m = 0.25;
    double max_edge_rotation_deg = 1.0;
    // Consensus over sampled spanning trees before the pose graph, with its ambiguity and
    // weak-bridge tests (edge_consensus.hpp). register_initial sets its edge tolerances to
    // max_edge_* above and its sensor separation to pair.min_sensor_separation_m.
    // The weak-bridge test is on here (EdgeConsensusParams leaves it off): a sensor reached
    // only through a weakly constrained pair that no cycle confirms is refused. In a
    // station of two nothing can contradict a look-alike, or a G-ICP slide along a street,
    // that passes every pairwise check; the daemon retries a refused sensor on later
    // frames, while a wrong pose would stay. The threshold sits between the wrong and the
    // right candidates measured on the simulator's sweeps and captures and clear of the
    // real rigs' pairs (bench/BENCHMARK.md, "weak bridges").
    EdgeConsensusParams consensus = [] {
        EdgeConsensusParams c;
        c.min_bridge_information_per_inlier = 2.6;
        return c;
    }();
    // The last, tighter G-ICP run on the pairs the consensus kept (edge_polish.hpp).
    // register_initial sets its G-ICP settings and r_c from `pair`.
    EdgePolishParams polish{};
    // Optional stop request, read between sensors and between pairs (a worker thread's
    // job is cancelled when the daemon stops): once set, the remaining work is skipped
    // and no sensor is registered (status kCancelled). Must outlive the call.
    const std::atomic<bool>* cancel = nullptr;
    bool cancel_requested() const {
        return cancel != nullptr && cancel->load(std::memory_order_acquire);
    }
    // Optional progress report (a command line's progress): the stage ("features", "pairs",
    // "pose graph"), how many of its items are done and how many there are. Called from
    // the worker threads, one call at a time.
    std::function<void(const char* stage, std::size_t done, std::size_t total)> on_progress;
};

// Sets the parameters the paper ties together: r_c = the largest octree voxel size.
InitialRegistrationParams default_initial_registration_params();

enum class SensorRegistrationStatus {
    kRegistered,
    kEmptyCloud,                   // no points (after pre-processing)
    kTooFewKeypoints,              // too little structure for descriptors
    kDegenerate,                   // sees a plane only
    kNoConsistentCorrespondences,  // no pair with another sensor survived RANSAC / G-ICP
    kNotConnectedToRoot,           // registered against others, but no path to the root
    kAmbiguous,                    // a look-alike placement explains the data as well
                                   // (edge_consensus.hpp); refused, not guessed
    kUnconfirmed,                  // reached through one weakly constrained pair that no
                                   // cycle confirms (edge_consensus.hpp); refused, not guessed
    kCancelled,                    // InitialRegistrationParams::cancel was set
};

const char* to_string(SensorRegistrationStatus status);

struct SensorRegistration {
    bool registered = false;
    SensorRegistrationStatus status = SensorRegistrationStatus::kEmptyCloud;
    // Valid only when registered (identity otherwise, never an estimate).
    Eigen::Isometry3d T_root_sensor = Eigen::Isometry3d::Identity();
    std::size_t num_input_points = 0;
    std::size_t num_preprocessed_points = 0;
    std::size_t num_downsampled_points = 0;
    std::size_t num_keypoints = 0;
    SensorFeatureTimings timings;
    // The sensor's road plane in its own frame (found = false when none), for a road-aligned
    // world frame (core/pipeline/world_frame.hpp); set whether or not the sensor was registered.
    GroundPlane ground;
};

// Wall-clock seconds per stage (the per-sensor and per-pair stages run in parallel; their
// CPU sums are in SensorRegistration::timings and PairResult::timings).
struct InitialRegistrationTimings {
    double features_s = 0.0;
    double pairs_s = 0.0;
    double polish_s = 0.0;
    double pose_graph_s = 0.0;
    double total_s = 0.0;
};

struct InitialRegistrationResult {
    std::vector<SensorRegistration> sensors;
    std::vector<PairResult> pairs;  // every pair i > j, in order (1,0), (2,0), (2,1), ...
    EdgePolishSummary polish;
    PoseGraphSummary pose_graph;
    InitialRegistrationTimings timings;
    std::size_t num_registered() const;
};

// Time inside each stage summed over the sensors and over the pairs. They run in
// parallel, so the sums exceed the wall-clock stage times in result.timings.
struct StageTimeSums {
    SensorFeatureTimings features;
    PairTimings pairs;
};
StageTimeSums sum_stage_timings(const InitialRegistrationResult& result);

InitialRegistrationResult register_initial(
    const std::vector<PointCloud>& clouds,
    const InitialRegistrationParams& params = default_initial_registration_params(),
    int num_threads = 1);

}  // namespace lidarfuse::core
