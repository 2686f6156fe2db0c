#include "core/preprocess/octree_downsample.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/common/angles.hpp"

namespace lidarfuse::core {

namespace {

Eigen::Vector3d fold(const Eigen::Vector3d& n) { return n.z() < 0.0 ? Eigen::Vector3d(-n) : n; }
}  // namespace

// --- sphere voting ----------------------------------------------------------------------
// Cells: polar rings of equal width on the upper hemisphere, each ring cut into azimuth
// sectors of about the same arc length, so the cells have roughly equal area. Neighbors
// are the cells whose centre axes lie within 1.5 cell widths (the axis angle uses |dot|,
// so cells on opposite sides of the equator are neighbors too, handling the fold).

NormalVoting::NormalVoting(double cell_deg, double agreement_angle_deg) {
    const double cell_rad = std::clamp(cell_deg, 1.0, 45.0) * kPi / 180.0;
    const int rings = std::max(1, static_cast<int>(std::ceil(0.5 * kPi / cell_rad)));
    ring_width_rad_ = 0.5 * kPi / rings;
    cos_agreement_ = std::cos(std::clamp(agreement_angle_deg, 0.0, 90.0) * kPi / 180.0);
    ring_offset_.push_back(0);
    for (int r = 0; r < rings; ++r) {
        const double theta = (r + 0.5) * ring_width_rad_;
        const int sectors = std::max(
            1, static_cast<int>(std::lround(2.0 * kPi * std::sin(theta) / ring_width_rad_)));
        for (int s = 0; s < sectors; ++s) {
            const double phi = (s + 0.5) * 2.0 * kPi / sectors;
            centres_.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                                  std::cos(theta));
        }
        ring_offset_.push_back(static_cast<int>(centres_.size()));
    }
    const double cos_neighbor = std::cos(1.5 * ring_width_rad_);
    neighbors_.resize(centres_.size());
    for (std::size_t i = 0; i < centres_.size(); ++i) {
        for (std::size_t j = 0; j < centres_.size(); ++j) {
            if (std::abs(centres_[i].dot(centres_[j])) >= cos_neighbor) {
                neighbors_[i].push_back(static_cast<int>(j));
            }
        }
    }
    votes_.assign(centres_.size(), 0);
}

int NormalVoting::cell_of(const Eigen::Vector3d& unit) const {
    const Eigen::Vector3d n = fold(unit);
    const int rings = static_cast<int>(ring_offset_.size()) - 1;
    const double theta = std::acos(std::clamp(n.z(), -1.0, 1.0));
    const int r = std::clamp(static_cast<int>(theta / ring_width_rad_), 0, rings - 1);
    const int sectors = ring_offset_[r + 1] - ring_offset_[r];
    double phi = std::atan2(n.y(), n.x());
    if (phi < 0.0) phi += 2.0 * kPi;
    const int s = std::clamp(static_cast<int>(phi / (2.0 * kPi) * sectors), 0, sectors - 1);
    return ring_offset_[r] + s;
}

NormalVoting::Vote NormalVoting::dominant(const std::vector<Eigen::Vector3d>& normals,
                                          const std::uint32_t* indices, std::size_t count) {
    Vote vote;
    if (count == 0) return vote;
    std::fill(votes_.begin(), votes_.end(), 0);
    for (std::size_t i = 0; i < count; ++i) {
        for (int cell : neighbors_[cell_of(normals[indices[i]])]) ++votes_[cell];
    }
    const auto best = std::max_element(votes_.begin(), votes_.end()) - votes_.begin();
    Eigen::Vector3d direction = centres_[best];
    // Refine: mean of the sign-aligned normals that agree with the current axis (twice, so
    // the cell quantisation does not bias the agreement test).
    for (int round = 0; round < 2; ++round) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (std::size_t i = 0; i < count; ++i) {
            const Eigen::Vector3d& n = normals[indices[i]];
            const double c = n.dot(direction);
            if (std::abs(c) >= cos_agreement_) sum += c < 0.0 ? Eigen::Vector3d(-n) : n;
        }
        if (sum.squaredNorm() > 0.0) direction = sum.normalized();
    }
    std::size_t agreeing = 0;
    for (std::size_t i = 0; i < count; ++i) {
        if (std::abs(normals[indices[i]].dot(direction)) >= cos_agreement_) ++agreeing;
    }
    vote.direction = direction;
    vote.agreeing_share = static_cast<double>(agreeing) / static_cast<double>(count);
    return vote;
}

// --- octree -----------------------------------------------------------------------------

namespace {

class OctreeBuilder {
public:
    OctreeBuilder(const PointCloud& cloud, const std::vector<double>& curvature,
                  const OctreeDownsampleParams& params, OctreeDownsampleResult* out)
        : cloud_(cloud),
          curvature_(curvature),
          params_(params),
          voting_(params.sphere_cell_deg, params.agreement_angle_deg),
          out_(out) {}

    // indices_[begin, end) lie in the cube [corner, corner + size).
    void build(std::uint32_t* indices, std::size_t count, const Eigen::Vector3d& corner,
               double size) {
        const bool can_split =
            count >= static_cast<std::size_t>(std::max(params_.min_points_to_split, 2)) &&
            0.5 * size >= params_.min_voxel_size_m * (1.0 - 1e-9);
        const NormalVoting::Vote vote = voting_.dominant(cloud_.normals, indices, count);
        if (!can_split || vote.agreeing_share >= params_.min_agreement_share) {
            emit_leaf(indices, count, size, vote.direction);
            return;
        }
        // Counting sort of the points into the 8 octants.
        const Eigen::Vector3d centre = corner + Eigen::Vector3d::Constant(0.5 * size);
        std::array<std::size_t, 9> start{};
        scratch_.resize(count);
        std::vector<std::uint8_t> octant(count);
        for (std::size_t i = 0; i < count; ++i) {
            const Eigen::Vector3d& p = cloud_.points[indices[i]];
            octant[i] = static_cast<std::uint8_t>((p.x() >= centre.x() ? 1 : 0) |
                                                  (p.y() >= centre.y() ? 2 : 0) |
                                                  (p.z() >= centre.z() ? 4 : 0));
            ++start[octant[i] + 1];
        }
        for (int o = 0; o < 8; ++o) start[o + 1] += start[o];
        std::array<std::size_t, 8> fill{};
        for (int o = 0; o < 8; ++o) fill[o] = start[o];
        for (std::size_t i = 0; i < count; ++i) scratch_[fill[octant[i]]++] = indices[i];
        std::copy(scratch_.begin(), scratch_.begin() + static_cast<std::ptrdiff_t>(count), indices);
        for (int o = 0; o < 8; ++o) {
            const std::size_t n = start[o + 1] - start[o];
            if (n == 0) continue;
            const Eigen::Vector3d child_corner(o & 1 ? centre.x() : corner.x(),
                                               o & 2 ? centre.y() : corner.y(),
                                               o & 4 ? centre.z() : corner.z());
            build(indices + start[o], n, child_corner, 0.5 * size);
        }
    }

private:
    void emit_leaf(const std::uint32_t* indices, std::size_t count, double size,
                   const Eigen::Vector3d& axis) {
        if (count < static_cast<std::size_t>(std::max(params_.min_points_per_leaf, 1))) return;
        Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
        Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
        double orientation = 0.0;
        double curvature_sum = 0.0;
        for (std::size_t i = 0; i < count; ++i) {
            const std::uint32_t j = indices[i];
            centroid += cloud_.points[j];
            const Eigen::Vector3d& n = cloud_.normals[j];
            const double c = n.dot(axis);
            orientation += c;
            normal_sum += c < 0.0 ? Eigen::Vector3d(-n) : n;
            if (!curvature_.empty()) curvature_sum += curvature_[j];
        }
        Eigen::Vector3d normal = normal_sum.squaredNorm() > 0.0 ? normal_sum.normalized() : axis;
        // Keep the input's orientation convention (e.g. towards the sensor).
        if (orientation < 0.0) normal = -normal;
        out_->cloud.points.push_back(centroid / static_cast<double>(count));
        out_->cloud.normals.push_back(normal);
        if (!curvature_.empty())
            out_->curvature.push_back(curvature_sum / static_cast<double>(count));
        out_->voxel_size_m.push_back(static_cast<float>(size));
        out_->point_count.push_back(static_cast<std::uint32_t>(count));
    }

    const PointCloud& cloud_;
    const std::vector<double>& curvature_;
    const OctreeDownsampleParams& params_;
    NormalVoting voting_;
    OctreeDownsampleResult* out_;
    std::vector<std::uint32_t> scratch_;
};

}  // namespace

OctreeDownsampleResult octree_downsample(const PointCloud& cloud,
                                         const std::vector<double>& curvature,
                                         const OctreeDownsampleParams& params) {
    OctreeDownsampleResult result;
    if (!cloud.has_normals() || !(params.max_voxel_size_m > 0.0)) return result;
    const bool use_curvature = curvature.size() == cloud.size();
    const std::vector<double> no_curvature;

    // Finite points only, and the bounding box they span.
    std::vector<std::uint32_t> indices;
    indices.reserve(cloud.size());
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        if (!cloud.points[i].allFinite() || !cloud.normals[i].allFinite()) continue;
        indices.push_back(static_cast<std::uint32_t>(i));
        lo = lo.cwiseMin(cloud.points[i]);
    }
    if (indices.empty()) return result;

    // Root cubes of max_voxel_size_m: sort by cell key, then build one octree per cell.
    const double root = params.max_voxel_size_m;
    auto key_of = [&](std::uint32_t i) {
        const Eigen::Vector3d c = ((cloud.points[i] - lo) / root).array().floor();
        // 21 bits per axis: 2M cells of `root` per axis is far beyond any LiDAR range.
        return (static_cast<std::uint64_t>(c.x()) << 42) |
               (static_cast<std::uint64_t>(c.y()) << 21) | static_cast<std::uint64_t>(c.z());
    };
    std::vector<std::uint64_t> keys(cloud.size());
    for (std::uint32_t i : indices) keys[i] = key_of(i);
    std::stable_sort(indices.begin(), indices.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });

    OctreeBuilder builder(cloud, use_curvature ? curvature : no_curvature, params, &result);
    std::size_t begin = 0;
    while (begin < indices.size()) {
        std::size_t end = begin + 1;
        while (end < indices.size() && keys[indices[end]] == keys[indices[begin]]) ++end;
        const std::uint64_t key = keys[indices[begin]];
        const Eigen::Vector3d cell(static_cast<double>(key >> 42),
                                   static_cast<double>((key >> 21) & 0x1FFFFF),
                                   static_cast<double>(key & 0x1FFFFF));
        builder.build(indices.data() + begin, end - begin, lo + cell * root, root);
        begin = end;
    }
    return result;
}

}  // namespace lidarfuse::core
