#pragma once
// Pose accuracy as the paper evaluates it (PAPER.md, "Evaluation"), plus a stricter figure.
//
// Estimates are T_root_sensor (root = the root sensor at its first frame); ground truth is
// T_world_sensor. Two ways to compare them:
//  - aligned (the paper's): a rigid T_coord, fitted by SVD (Umeyama, no scale) from the
//    estimated to the true sensor positions over all matched samples, maps estimates into
//    the world: T~ = T_coord * T^; E_trans = |p~ - p|, E_rot = arccos((tr(R~ R^T) - 1) / 2)
//    (computed in the atan2 form of se3.hpp, which keeps its precision near zero).
//    (PAPER.md writes R~ = R^ R_coord^-1; composing the rigid maps gives R_coord R^, which
//    is what is used here.)
//  - strict: no fitted alignment; both re-expressed relative to the root sensor at its first
//    matched frame, T_gt = T_world_root0^-1 * T_world_sensor and T_est = T_fused_root0^-1 *
//    T_fused_sensor, compared directly. The estimate's frame (world.frame: sensor, road or
//    geo) cancels out: with `sensor` T_fused_root0 is the identity and nothing changes.
//  - world (optional, EvaluationParams::world): the estimate's own frame against the truth's
//    world. kRoad: only what a road frame fixes, each sensor's height (z) and up direction
//    (the angle between the world z axis seen from the sensor, R^T e_z, in both); the truth's world
//    must be road-aligned (the simulator's road is z = 0). kGeo: the poses directly, after adding
//    world_offset (the geo offset, T_world_fused's translation) to the estimate.
// Per sensor: RMSE over frames; then the mean over sensors.

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace lidarfuse::core {

struct TrajectorySample {
    std::int64_t frame = 0;
    std::int64_t t_ns = 0;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

// Samples per sensor name, in any order.
using Trajectories = std::map<std::string, std::vector<TrajectorySample>>;

struct EvaluationParams {
    // Root sensor of the estimate; empty: the estimated sensor whose earliest position is
    // nearest the frame's z axis (horizontal distance; ties by the rotation from identity):
    // the root is at the origin in the sensor frame, right above it in the road frame and
    // within the offset's rounding of it in the geo frame.
    std::string root_sensor;
    // Samples are matched per sensor by timestamp, nearest within this tolerance (ns).
    // 25 ms = half a frame at 20 Hz. When a file has t_ns = 0 everywhere, frames are matched.
    std::int64_t match_tolerance_ns = 25'000'000;
    enum class World { kNone, kRoad, kGeo };
    World world = World::kNone;
    Eigen::Vector3d world_offset = Eigen::Vector3d::Zero();  // kGeo: added to the estimate
};

struct SensorErrors {
    std::string sensor;
    std::size_t matched = 0;                    // estimate samples with a ground-truth partner
    std::size_t missing = 0;                    // ground-truth samples with no estimate
    double rmse_trans_m = 0, rmse_rot_deg = 0;  // aligned
    double strict_rmse_trans_m = 0, strict_rmse_rot_deg = 0;  // no fitted alignment
    double max_trans_m = 0, max_rot_deg = 0;                  // aligned
    // Strict translation RMSE over the first and the last 10% of matched samples (drift;
    // strict because a fitted alignment would spread a drift over the whole run).
    double first_tenth_rmse_trans_m = 0, last_tenth_rmse_trans_m = 0;
    // Per matched sample, in time order (for plots).
    // World (EvaluationParams::world): kRoad: height error (z, signed per sample) and up
    // direction error; kGeo: translation and rotation error, no alignment.
    double world_rmse_trans_m = 0, world_rmse_rot_deg = 0, world_max_trans_m = 0;
    std::vector<std::int64_t> t_ns;
    std::vector<double> trans_err_m, rot_err_deg, strict_trans_err_m, strict_rot_err_deg;
};

struct EvaluationResult {
    bool ok = false;
    std::string error;  // why not, when !ok
    std::string root_sensor;
    Eigen::Isometry3d T_world_root = Eigen::Isometry3d::Identity();  // the fitted T_coord
    // "svd": T_coord fitted from the sensor positions; "root": the positions do not span a
    // plane (fewer than three sensors, or in a line), so T_coord maps the estimated root at
    // its first match onto the true one (the aligned figures then equal the strict ones).
    std::string alignment;
    std::vector<SensorErrors> sensors;
    double mean_rmse_trans_m = 0, mean_rmse_rot_deg = 0;
    double mean_strict_rmse_trans_m = 0, mean_strict_rmse_rot_deg = 0;
    double mean_world_rmse_trans_m = 0, mean_world_rmse_rot_deg = 0;
};

EvaluationResult evaluate_trajectories(const Trajectories& ground_truth,
                                       const Trajectories& estimate,
                                       const EvaluationParams& params = {});

}  // namespace lidarfuse::core
