#pragma once
// The ground plane a roadside LiDAR sees, and the levelling transform it gives (our
// addition to the paper's initial registration, see ground_aligned_search.hpp).
//
// Every sensor of a station watches the same road from a pole, "not mounted upside down"
// (PAPER.md): the road is the largest surface whose normal lies within `max_tilt_deg` of
// the sensor's own +z axis. Its normal is the local up direction and the sensor's distance
// to it the mounting height, so the 6-DOF pose between two sensors reduces to yaw and a
// horizontal translation once both clouds are levelled.
//
//   1. candidates: points whose normal is within max_tilt_deg of +z (sign-folded);
//   2. up direction: the mean of the candidate normals within `agreement_deg` of the
//      densest normal direction (vote over a discretised sphere, normal_voting);
//   3. height: the densest bin of the candidates' offsets along up (h = -up . p), so
//      roofs, car tops and the sidewalk lose against the road;
//   4. `refine_rounds` times: plane fitted by PCA to the points within
//      `inlier_distance_m` of the current plane (points of any normal).
//
// Frames: input in the sensor frame (sensor at the origin). The levelled ("ground") frame
// has z = up, its origin on the ground below the sensor, and the sensor's x axis projected
// onto the ground as x (the smallest rotation that takes up to +z). Deterministic,
// single-threaded, O(N).

#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

namespace lidarfuse::core {

struct GroundPlaneParams {
    // Largest angle between the sensor's +z and the ground normal (deg).
    double max_tilt_deg = 50.0;
    // Normals within this angle of the dominant direction vote for it (deg).
    double agreement_deg = 10.0;
    // Height histogram bin (m).
    double height_bin_m = 0.2;
    // PCA refinement: points within this distance of the plane (m), and rounds.
    double inlier_distance_m = 0.25;
    int refine_rounds = 2;
    // Fewer plane inliers than this: no ground found.
    std::size_t min_inliers = 50;
};

struct GroundPlane {
    bool found = false;
    Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // unit, sensor frame, up . z > 0
    double sensor_height_m = 0.0;                   // sensor origin above the plane
    std::size_t num_inliers = 0;
    double rms_m = 0.0;  // plane fit residual of the inliers
    // T_ground_sensor: sensor frame -> levelled ground frame (see the file comment).
    Eigen::Isometry3d T_ground_sensor = Eigen::Isometry3d::Identity();
};

// `points` with unit `normals` (same size; any sign), in the sensor frame.
GroundPlane estimate_ground_plane(const std::vector<Eigen::Vector3d>& points,
                                  const std::vector<Eigen::Vector3d>& normals,
                                  const GroundPlaneParams& params = {});

}  // namespace lidarfuse::core
