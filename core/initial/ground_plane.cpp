#include "core/initial/ground_plane.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>

#include "core/common/angles.hpp"
#include "core/preprocess/octree_downsample.hpp"

namespace lidarfuse::core {

namespace {

// Smallest rotation taking `up` (unit) to +z.
Eigen::Matrix3d levelling_rotation(const Eigen::Vector3d& up) {
    return Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

}  // namespace

GroundPlane estimate_ground_plane(const std::vector<Eigen::Vector3d>& points,
                                  const std::vector<Eigen::Vector3d>& normals,
                                  const GroundPlaneParams& params) {
    GroundPlane plane;
    if (points.size() != normals.size() || points.empty()) return plane;

    // 1-2. Up-ish normals, and their dominant direction.
    const double cos_tilt = std::cos(params.max_tilt_deg * kDegToRad);
    std::vector<std::uint32_t> candidates;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (points[i].allFinite() && normals[i].allFinite() &&
            std::abs(normals[i].z()) >= cos_tilt) {
            candidates.push_back(static_cast<std::uint32_t>(i));
        }
    }
    if (candidates.size() < params.min_inliers) return plane;
    NormalVoting voting(params.agreement_deg, params.agreement_deg);
    Eigen::Vector3d up = voting.dominant(normals, candidates.data(), candidates.size()).direction;
    if (up.z() < 0.0) up = -up;
    if (up.z() < cos_tilt) return plane;

    // 3. Densest height bin among the candidates that agree with up.
    const double cos_agree = std::cos(params.agreement_deg * kDegToRad);
    std::map<std::int64_t, std::size_t> bins;
    for (std::uint32_t i : candidates) {
        if (std::abs(normals[i].dot(up)) < cos_agree) continue;
        ++bins[static_cast<std::int64_t>(std::floor(-up.dot(points[i]) / params.height_bin_m))];
    }
    if (bins.empty()) return plane;
    std::int64_t best_bin = bins.begin()->first;
    std::size_t best_count = 0;
    for (const auto& [bin, count] : bins) {
        // Neighboring bins count too: a plane straddling a bin edge is not split.
        const auto prev = bins.find(bin - 1);
        const auto next = bins.find(bin + 1);
        const std::size_t total = count + (prev != bins.end() ? prev->second : 0) +
                                  (next != bins.end() ? next->second : 0);
        if (total > best_count) {
            best_count = total;
            best_bin = bin;
        }
    }
    double height = (static_cast<double>(best_bin) + 0.5) * params.height_bin_m;

    // 4. PCA refinement on the points near the plane up . p + height = 0.
    std::size_t inliers = 0;
    double rms = 0.0;
    for (int round = 0; round < std::max(1, params.refine_rounds); ++round) {
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        std::vector<std::uint32_t> near;
        for (std::size_t i = 0; i < points.size(); ++i) {
            if (!points[i].allFinite()) continue;
            if (std::abs(up.dot(points[i]) + height) <= params.inlier_distance_m) {
                near.push_back(static_cast<std::uint32_t>(i));
                mean += points[i];
            }
        }
        if (near.size() < params.min_inliers) return plane;
        mean /= static_cast<double>(near.size());
        Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
        for (std::uint32_t i : near) scatter += (points[i] - mean) * (points[i] - mean).transpose();
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
        Eigen::Vector3d n = solver.eigenvectors().col(0);
        if (n.dot(up) < 0.0) n = -n;
        if (n.z() < cos_tilt) break;  // the fit left the allowed tilt: keep the last plane
        up = n.normalized();
        height = -up.dot(mean);
        inliers = near.size();
        rms = std::sqrt(std::max(0.0, solver.eigenvalues()(0)) / static_cast<double>(near.size()));
    }
    if (inliers < params.min_inliers || !(height > 0.0)) return plane;

    plane.found = true;
    plane.up = up;
    plane.sensor_height_m = height;
    plane.num_inliers = inliers;
    plane.rms_m = rms;
    plane.T_ground_sensor.linear() = levelling_rotation(up);
    plane.T_ground_sensor.translation() = Eigen::Vector3d(0.0, 0.0, height);
    return plane;
}

}  // namespace lidarfuse::core
