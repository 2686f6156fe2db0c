#include "core/features/sensor_features.hpp"

#include <Eigen/Eigenvalues>

#include "core/common/stopwatch.hpp"
#include "core/preprocess/voxel_grid.hpp"

namespace lidarfuse::core {

namespace {

// Second largest eigenvalue of (1/N) sum n n^T: ~0 when every normal is parallel.
double normal_spread(const std::vector<Eigen::Vector3d>& normals) {
    if (normals.empty()) return 0.0;
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& n : normals) scatter += n * n.transpose();
    scatter /= static_cast<double>(normals.size());
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter, Eigen::EigenvaluesOnly);
    return solver.eigenvalues()(1);
}

// Step 2: pre-processing (range crop, optional voxel grid, statistical outliers). Only
// positions are carried (normals are computed after).
PointCloud preprocess(const PointCloud& cloud, const SensorFeatureParams& params, int threads) {
    PointCloud positions;
    positions.points = cloud.points;
    PointCloud cropped;
    filter_range(positions, params.range, &cropped);
    if (params.pre_voxel_size_m > 0.0) {
        // Near the pole the scan is far denser than any later stage uses.
        VoxelGridParams pre;
        pre.voxel_size_m = params.pre_voxel_size_m;
        cropped = voxel_downsample(cropped.points, pre);
    }
    PointCloud clean;
    if (params.remove_outliers &&
        cropped.size() > static_cast<std::size_t>(params.outliers.k_neighbors)) {
        remove_statistical_outliers(cropped, params.outliers, &clean, nullptr, threads);
    } else {
        clean = std::move(cropped);
    }
    return clean;
}

// Normals (towards the sensor) into the cloud, and the curvature, once per cloud.
std::vector<double> normals_and_curvature(const NormalParams& params, int threads,
                                          PointCloud* cloud) {
    NormalParams normal_params = params;
    normal_params.compute_normals = true;
    normal_params.compute_covariances = false;
    std::vector<double> curvature;
    estimate_normals_covariances(cloud, normal_params, &curvature, threads);
    return curvature;
}

// A G-ICP / p2p cloud: the points on a voxel grid (m), with covariances from k neighbors
// when there are enough points for them.
GicpCloud covariance_cloud(const std::vector<Eigen::Vector3d>& points, double voxel_size_m,
                           int k_neighbors, int threads) {
    VoxelGridParams voxel;
    voxel.voxel_size_m = voxel_size_m;
    PointCloud voxels = voxel_downsample(points, voxel);
    NormalParams cov_params;
    cov_params.k_neighbors = k_neighbors;
    cov_params.compute_normals = false;
    cov_params.compute_covariances = true;
    if (voxels.size() < 3) return GicpCloud(std::move(voxels));
    return GicpCloud(std::move(voxels), cov_params, 10, threads);
}

// The G-ICP cloud and the finer polish cloud (left empty when off).
void build_registration_clouds(const std::vector<Eigen::Vector3d>& points,
                               const SensorFeatureParams& params, int threads,
                               SensorFeatures* out) {
    out->gicp =
        covariance_cloud(points, params.gicp_voxel_size_m, params.gicp_k_neighbors, threads);
    if (params.polish_voxel_size_m > 0.0) {
        out->polish =
            covariance_cloud(points, params.polish_voxel_size_m, params.gicp_k_neighbors, threads);
    }
}

// Step 4, second half: FPFH at the keypoints of the octree cloud, and their positions and
// normals.
void describe_keypoints(const FpfhParams& params, int threads, SensorFeatures* out) {
    const PointCloud& cloud = out->octree.cloud;
    out->descriptors = compute_fpfh(cloud, out->keypoints, params, threads);
    for (std::uint32_t k : out->keypoints) {
        out->keypoint_points.push_back(cloud.points[k]);
        out->keypoint_normals.push_back(cloud.normals[k]);
    }
}

}  // namespace

const char* to_string(SensorFeatureStatus status) {
    switch (status) {
        case SensorFeatureStatus::kOk:
            return "ok";
        case SensorFeatureStatus::kEmptyCloud:
            return "empty cloud";
        case SensorFeatureStatus::kPlaneOnly:
            return "degenerate: plane only";
        case SensorFeatureStatus::kTooFewKeypoints:
            return "too few keypoints";
    }
    return "unknown";
}

SensorFeatures compute_sensor_features(const PointCloud& cloud, const SensorFeatureParams& params,
                                       std::size_t min_keypoints, int num_threads) {
    SensorFeatures out;
    out.num_input_points = cloud.size();
    const int threads = std::max(1, num_threads);

    Stopwatch stage;
    PointCloud clean = preprocess(cloud, params, threads);
    out.num_preprocessed_points = clean.size();
    out.timings.preprocess_s = stage.seconds();
    if (clean.size() < static_cast<std::size_t>(std::max(params.normals.k_neighbors, 3)))
        return out;

    stage.restart();
    const std::vector<double> curvature = normals_and_curvature(params.normals, threads, &clean);
    out.timings.normals_s = stage.seconds();

    // Step 3: normal-adaptive octree.
    stage.restart();
    out.octree = octree_downsample(clean, curvature, params.octree);
    out.normal_spread = normal_spread(out.octree.cloud.normals);
    out.timings.octree_s = stage.seconds();

    // The G-ICP / p2p clouds (also built for failed sensors: cheap, and keeps the result
    // uniform).
    stage.restart();
    build_registration_clouds(clean.points, params, threads, &out);
    out.timings.gicp_cloud_s = stage.seconds();

    if (out.octree.cloud.size() < 3) return out;  // kEmptyCloud
    if (out.normal_spread < params.min_normal_spread) {
        out.status = SensorFeatureStatus::kPlaneOnly;
        return out;
    }

    // Step 4: SIFT-3D keypoints on curvature, FPFH at them, both on the octree cloud.
    stage.restart();
    out.keypoints =
        detect_sift_keypoints(out.octree.cloud.points, out.octree.curvature, params.sift, threads)
            .indices;
    out.timings.keypoints_s = stage.seconds();
    if (out.keypoints.size() < min_keypoints) {
        out.status = SensorFeatureStatus::kTooFewKeypoints;
        return out;
    }
    stage.restart();
    describe_keypoints(params.fpfh, threads, &out);
    out.timings.fpfh_s = stage.seconds();

    // The road plane and the sensor's free space, from every pre-processed return.
    stage.restart();
    out.ground = estimate_ground_plane(clean.points, clean.normals, params.ground);
    out.free_space = FreeSpaceMap(clean.points, clean.normals, params.free_space);
    out.timings.ground_s = stage.seconds();
    out.status = SensorFeatureStatus::kOk;
    return out;
}

}  // namespace lidarfuse::core
