#pragma once
// Per-sensor half of the initial registration (PAPER.md steps 2-4), everything that
// depends on one cloud only and is computed once per sensor, whatever the number of pairs:
//   pre-process (range crop, statistical outliers) -> normals and curvature (k-NN) ->
//   normal-adaptive octree downsampling -> SIFT-3D keypoints on curvature -> FPFH at the
//   keypoints (over the octree cloud),
// plus the cloud the G-ICP refinement and the p2p score use: a voxel grid of the
// pre-processed points with G-ICP covariances, wrapped as a GicpCloud.
//
// The cloud is in its sensor's frame (the sensor at the origin: ranges and the normal
// orientation refer to it). Deterministic; `num_threads` OpenMP threads for the stages.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "core/common/point_cloud.hpp"
#include "core/features/fpfh.hpp"
#include "core/features/sift_keypoints.hpp"
#include "core/initial/ground_plane.hpp"
#include "core/preprocess/normals.hpp"
#include "core/preprocess/octree_downsample.hpp"
#include "core/preprocess/preprocess.hpp"
#include "core/registration/free_space_check.hpp"
#include "core/registration/gicp.hpp"

namespace lidarfuse::core {

struct SensorFeatureParams {
    RangeFilterParams range{1.0, 120.0, Eigen::Vector3d::Zero()};
    // Voxel grid (centroids) right after the range crop (m; 0 = off). Off: it saves outlier
    // and normal k-NN work, but cost accuracy on the simulated captures (bench/BENCHMARK.md).
    double pre_voxel_size_m = 0.0;
    bool remove_outliers = true;
    StatisticalOutlierParams outliers{};
    NormalParams normals{};  // normals + curvature on the pre-processed cloud
    OctreeDownsampleParams octree{};
    SiftKeypointParams sift{};
    FpfhParams fpfh{};
    // The road plane (on the pre-processed cloud: every return, with its normal; the octree
    // keeps few points of a large plane) that levels the sensor for the ground-aligned
    // candidate search (our addition, ground_aligned_search.hpp).
    GroundPlaneParams ground{};
    // The sensor's observed free space (free_space_check.hpp), from the pre-processed cloud
    // and its normals: the pair checks test the other sensor's G-ICP cloud against it.
    FreeSpaceParams free_space{};
    // G-ICP / p2p cloud: voxel size (m) and the k of its covariances.
    double gicp_voxel_size_m = 0.5;
    int gicp_k_neighbors = 20;
    // The finer cloud of the last G-ICP run on chosen pairs (edge_polish.hpp says why; same
    // k); 0: that run uses the G-ICP cloud above.
    double polish_voxel_size_m = 0.25;
    // The octree cloud is "plane only" when the second largest eigenvalue of its normals'
    // scatter matrix (1/N sum n n^T) is below this: every normal (nearly) parallel.
    double min_normal_spread = 0.02;
};

enum class SensorFeatureStatus {
    kOk,
    kEmptyCloud,       // nothing left after pre-processing (or too little for normals)
    kPlaneOnly,        // all normals parallel: no constraint on in-plane motion
    kTooFewKeypoints,  // fewer than min_keypoints SIFT keypoints
};

const char* to_string(SensorFeatureStatus status);

struct SensorFeatureTimings {
    double preprocess_s = 0.0;
    double normals_s = 0.0;
    double octree_s = 0.0;
    double keypoints_s = 0.0;
    double fpfh_s = 0.0;
    double ground_s = 0.0;      // the road plane and the free-space map
    double gicp_cloud_s = 0.0;  // the G-ICP and the polish clouds
};

struct SensorFeatures {
    SensorFeatureStatus status = SensorFeatureStatus::kEmptyCloud;
    std::size_t num_input_points = 0;
    std::size_t num_preprocessed_points = 0;
    OctreeDownsampleResult octree;                  // downsampled cloud with normals
    std::vector<std::uint32_t> keypoints;           // indices into octree.cloud
    std::vector<Eigen::Vector3d> keypoint_points;   // their positions (m, sensor frame)
    std::vector<Eigen::Vector3d> keypoint_normals;  // their unit normals (sensor frame)
    std::vector<FpfhDescriptor> descriptors;        // one per keypoint
    GicpCloud gicp;                                 // voxel cloud with covariances + k-d tree
    GicpCloud polish;                               // the finer one (empty when off)
    GroundPlane ground;                             // found = false when no road plane
    FreeSpaceMap free_space;                        // rays of the pre-processed cloud (kOk only)
    double normal_spread = 0.0;                     // see min_normal_spread
    SensorFeatureTimings timings;
};

// The sensor's up direction (unit, sensor frame): its road plane's normal where one was
// found, else its +z axis (PAPER.md: "not mounted upside down").
inline Eigen::Vector3d up_direction(const SensorFeatures& features) {
    return features.ground.found ? features.ground.up : Eigen::Vector3d::UnitZ();
}

// Needs at least `min_keypoints` keypoints for kOk.
SensorFeatures compute_sensor_features(const PointCloud& cloud, const SensorFeatureParams& params,
                                       std::size_t min_keypoints = 8, int num_threads = 1);

}  // namespace lidarfuse::core
