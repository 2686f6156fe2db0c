#include "core/initial/ground_plane.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "core/common/angles.hpp"
#include "core/preprocess/octree_downsample.hpp"

namespace lidarfuse::core {

namespace {

// Smallest rotation taking `up` (unit) to +z.
Eigen::Matrix3d levelling_rotation(const Eigen::Vector3d& up) {
    return Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// The points whose finite normal is within max_tilt_deg of the vertical (either sign).
std::vector<std::uint32_t> up_candidates(const std::vector<Eigen::Vector3d>& points,
                                         const std::vector<Eigen::Vector3d>& normals,
                                         double cos_tilt) {
    std::vector<std::uint32_t> candidates;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (points[i].allFinite() && normals[i].allFinite() &&
            std::abs(normals[i].z()) >= cos_tilt) {
            candidates.push_back(static_cast<std::uint32_t>(i));
        }
    }
    return candidates;
}

// The plane's offset along `up` (m, up . p + height = 0): the centre of the densest
// height_bin_m bin, with its neighbors, among the candidates whose normal agrees with up;
// none when no candidate agrees.
std::optional<double> densest_height(const std::vector<Eigen::Vector3d>& points,
                                     const std::vector<Eigen::Vector3d>& normals,
                                     const std::vector<std::uint32_t>& candidates,
                                     const Eigen::Vector3d& up, const GroundPlaneParams& params) {
    const double cos_agree = std::cos(params.agreement_deg * kDegToRad);
    std::map<std::int64_t, std::size_t> bins;
    for (std::uint32_t i : candidates) {
        if (std::abs(normals[i].dot(up)) < cos_agree) continue;
        ++bins[static_cast<std::int64_t>(std::floor(-up.dot(points[i]) / params.height_bin_m))];
    }
    if (bins.empty()) return std::nullopt;
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
    return (static_cast<double>(best_bin) + 0.5) * params.height_bin_m;
}

// The plane up . p + height = 0 (sensor frame) and its fit.
struct PlaneFit {
    Eigen::Vector3d up;
    double height = 0.0;      // m
    std::size_t inliers = 0;  // 0 until a refinement round kept its fit
    double rms_m = 0.0;
};

// PCA refinement on the points near the plane, refine_rounds times; a round whose fit
// leaves the allowed tilt ends it with the last plane. None when a round finds fewer than
// min_inliers points near the plane.
std::optional<PlaneFit> refine_plane(const std::vector<Eigen::Vector3d>& points, PlaneFit fit,
                                     double cos_tilt, const GroundPlaneParams& params) {
    for (int round = 0; round < std::max(1, params.refine_rounds); ++round) {
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        std::vector<std::uint32_t> near;
        for (std::size_t i = 0; i < points.size(); ++i) {
            if (!points[i].allFinite()) continue;
            if (std::abs(fit.up.dot(points[i]) + fit.height) <= params.inlier_distance_m) {
                near.push_back(static_cast<std::uint32_t>(i));
                mean += points[i];
            }
        }
        if (near.size() < params.min_inliers) return std::nullopt;
        mean /= static_cast<double>(near.size());
        Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
        for (std::uint32_t i : near) scatter += (points[i] - mean) * (points[i] - mean).transpose();
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
        Eigen::Vector3d n = solver.eigenvectors().col(0);
        if (n.dot(fit.up) < 0.0) n = -n;
        if (n.z() < cos_tilt) break;  // the fit left the allowed tilt: keep the last plane
        fit.up = n.normalized();
        fit.height = -fit.up.dot(mean);
        fit.inliers = near.size();
        fit.rms_m =
            std::sqrt(std::max(0.0, solver.eigenvalues()(0)) / static_cast<double>(near.size()));
    }
    return fit;
}

}  // namespace

GroundPlane estimate_ground_plane(const std::vector<Eigen::Vector3d>& points,
                                  const std::vector<Eigen::Vector3d>& normals,
                                  const GroundPlaneParams& params) {
    GroundPlane plane;
    if (points.size() != normals.size() || points.empty()) return plane;

    // 1-2. Up-ish normals, and their dominant direction.
    const double cos_tilt = std::cos(params.max_tilt_deg * kDegToRad);
    const std::vector<std::uint32_t> candidates = up_candidates(points, normals, cos_tilt);
    if (candidates.size() < params.min_inliers) return plane;
    NormalVoting voting(params.agreement_deg, params.agreement_deg);
    Eigen::Vector3d up = voting.dominant(normals, candidates.data(), candidates.size()).direction;
    if (up.z() < 0.0) up = -up;
    if (up.z() < cos_tilt) return plane;

    // 3. Densest height bin among the candidates that agree with up.
    const std::optional<double> height = densest_height(points, normals, candidates, up, params);
    if (!height) return plane;

    // 4. PCA refinement on the points near the plane up . p + height = 0.
    PlaneFit start;
    start.up = up;
    start.height = *height;
    const std::optional<PlaneFit> fit = refine_plane(points, start, cos_tilt, params);
    if (!fit || fit->inliers < params.min_inliers || !(fit->height > 0.0)) return plane;

    plane.found = true;
    plane.up = fit->up;
    plane.sensor_height_m = fit->height;
    plane.num_inliers = fit->inliers;
    plane.rms_m = fit->rms_m;
    plane.T_ground_sensor.linear() = levelling_rotation(fit->up);
    plane.T_ground_sensor.translation() = Eigen::Vector3d(0.0, 0.0, fit->height);
    return plane;
}

}  // namespace lidarfuse::core
