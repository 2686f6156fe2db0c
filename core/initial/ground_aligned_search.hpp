#pragma once
// Candidate transforms between two roadside sensors by an exhaustive vote over yaw and
// horizontal translation in their levelled ground frames (our addition to the paper's
// steps 5-8; the candidates go through the same refinement and checks as RANSAC's).
//
// Why: on the simulated stations the FPFH descriptors of the same place seen by two
// sensors are barely more alike than those of random places (median rank of the true
// partner among all target keypoints 0.15-0.4, random = 0.5), so descriptor matches are
// 0.1-1 % right and 3-point RANSAC mostly proposes look-alikes. But about half of the
// keypoints in the common view are repeated within 1 m. Once both clouds are levelled on
// their ground planes (ground_plane.hpp) the pose has 3 unknowns (yaw, tx, ty), and a
// Hough vote finds them from keypoint positions alone:
//   gate: a source/target keypoint pair may vote only if their heights above ground differ
//         by <= max_height_difference_m, their normals' angles to the vertical by
//         <= max_normal_tilt_difference_deg, and the target is among the source's
//         `descriptor_rank_share` nearest descriptors (a weak, cheap filter);
//   vote: for every yaw step, each gated pair votes for t = q_t - R(yaw) q_s (horizontal,
//         `cell_m` cells); a peak is the largest 2x2-cell sum;
//   keep: the best peaks over all yaws, apart by >= nms_yaw_deg or >= nms_translation_m.
// A look-alike (the intersection's arms, the same facade further down the street) gives a
// peak too; the caller's free-space and p2p checks decide between them.
//
// Frames: keypoints in their sensor frames; T_ground_sensor from estimate_ground_plane.
// Returns T_target_source (sensor frames), the 4-DOF vote result (roll and pitch between
// the sensors come from the two ground planes). Deterministic; single-threaded.

#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "core/features/fpfh.hpp"
#include "core/registration/correspondence.hpp"

namespace lidarfuse::core {

struct GroundAlignedSearchParams {
    double max_height_difference_m = 1.0;
    // Keypoints lower than this above the ground do not vote (m): kerbs and road marks are
    // long lines that align with each other under many wrong transforms.
    double min_height_m = 0.5;
    double max_normal_tilt_difference_deg = 20.0;
    // Share of the target keypoints (nearest in descriptor space) each source keypoint may
    // pair with; 1 disables the descriptor gate.
    double descriptor_rank_share = 1.0;
    double yaw_step_deg = 1.0;
    double cell_m = 1.0;
    // Largest horizontal distance between the sensors considered (m).
    double max_translation_m = 200.0;
    // Peaks kept over all yaws, and the smallest vote count of a peak.
    int max_peaks = 10;
    int min_votes = 6;
    double nms_yaw_deg = 5.0;
    double nms_translation_m = 5.0;
    // A voting pair within this 3-D distance under a peak's transform is its inlier (m).
    double inlier_distance_m = 1.0;
};

struct GroundAlignedCandidate {
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    double yaw_deg = 0.0;  // of the source ground frame in the target ground frame
    Eigen::Vector2d translation_m = Eigen::Vector2d::Zero();
    int votes = 0;            // the peak's 2x2-cell sum
    Correspondences inliers;  // gated pairs that agree within inlier_distance_m
};

struct GroundAlignedKeypoints {
    const std::vector<Eigen::Vector3d>* points = nullptr;   // sensor frame
    const std::vector<Eigen::Vector3d>* normals = nullptr;  // unit, sensor frame
    const std::vector<FpfhDescriptor>* descriptors = nullptr;
    Eigen::Isometry3d T_ground_sensor = Eigen::Isometry3d::Identity();
};

// Best candidates first (most votes).
std::vector<GroundAlignedCandidate> ground_aligned_search(
    const GroundAlignedKeypoints& source, const GroundAlignedKeypoints& target,
    const GroundAlignedSearchParams& params = {});

}  // namespace lidarfuse::core
