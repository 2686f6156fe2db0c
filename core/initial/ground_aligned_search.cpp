#include "core/initial/ground_aligned_search.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

#include "core/common/angles.hpp"

namespace lidarfuse::core {

namespace {

struct Peak {
    int votes = 0;
    double yaw_deg = 0.0;
    Eigen::Vector2d t = Eigen::Vector2d::Zero();
};

// Every array given with one entry per point, at least 3 points a side, a positive cell and
// yaw step.
bool inputs_usable(const GroundAlignedKeypoints& source, const GroundAlignedKeypoints& target,
                   const GroundAlignedSearchParams& params) {
    if (source.points == nullptr || target.points == nullptr || source.normals == nullptr ||
        target.normals == nullptr || source.descriptors == nullptr ||
        target.descriptors == nullptr) {
        return false;
    }
    const std::size_t ns = source.points->size();
    const std::size_t nt = target.points->size();
    return !(ns < 3 || nt < 3 || source.normals->size() != ns || target.normals->size() != nt ||
             source.descriptors->size() != ns || target.descriptors->size() != nt ||
             !(params.cell_m > 0.0) || !(params.yaw_step_deg > 0.0));
}

// Keypoints in the ground frame, and each one's normal angle to the vertical (deg).
struct GroundPoints {
    std::vector<Eigen::Vector3d> q;
    std::vector<double> tilt_deg;
};

GroundPoints to_ground(const GroundAlignedKeypoints& k) {
    const std::size_t n = k.points->size();
    GroundPoints g;
    g.q.resize(n);
    g.tilt_deg.resize(n);
    const Eigen::Matrix3d R = k.T_ground_sensor.linear();
    for (std::size_t i = 0; i < n; ++i) {
        g.q[i] = k.T_ground_sensor * (*k.points)[i];
        const double nz = std::abs((R * (*k.normals)[i]).z());
        g.tilt_deg[i] = std::acos(std::min(1.0, nz)) / kDegToRad;
    }
    return g;
}

// Target point b above the minimum height, at about source point a's height and tilt.
bool passes_geometric_gate(const GroundPoints& s, std::size_t a, const GroundPoints& t,
                           std::size_t b, const GroundAlignedSearchParams& params) {
    return t.q[b].z() >= params.min_height_m &&
           std::abs(s.q[a].z() - t.q[b].z()) <= params.max_height_difference_m &&
           std::abs(s.tilt_deg[a] - t.tilt_deg[b]) <= params.max_normal_tilt_difference_deg;
}

// The pairs that pass the gate: height, normal tilt and (when it leaves out any) the target's
// descriptor rank among the source point's nearest.
Correspondences gate_correspondences(const GroundAlignedKeypoints& source,
                                     const GroundAlignedKeypoints& target, const GroundPoints& s,
                                     const GroundPoints& t,
                                     const GroundAlignedSearchParams& params) {
    const std::size_t ns = s.q.size();
    const std::size_t nt = t.q.size();
    const auto rank_limit = static_cast<std::size_t>(
        std::ceil(std::clamp(params.descriptor_rank_share, 0.0, 1.0) * static_cast<double>(nt)));
    Correspondences gated;
    std::vector<std::pair<float, std::uint32_t>> by_distance(nt);
    const bool rank_gate = rank_limit < nt;
    for (std::size_t a = 0; a < ns; ++a) {
        if (s.q[a].z() < params.min_height_m) continue;
        if (!rank_gate) {
            for (std::size_t b = 0; b < nt; ++b) {
                if (passes_geometric_gate(s, a, t, b, params))
                    gated.push_back(
                        {static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b), 0.0f});
            }
            continue;
        }
        for (std::size_t b = 0; b < nt; ++b) {
            by_distance[b] = {((*source.descriptors)[a] - (*target.descriptors)[b]).squaredNorm(),
                              static_cast<std::uint32_t>(b)};
        }
        std::nth_element(by_distance.begin(), by_distance.begin() + rank_limit, by_distance.end());
        for (std::size_t r = 0; r < rank_limit; ++r) {
            const std::uint32_t b = by_distance[r].second;
            if (passes_geometric_gate(s, a, t, b, params))
                gated.push_back(
                    {static_cast<std::uint32_t>(a), b, std::sqrt(by_distance[r].first)});
        }
    }
    return gated;
}

// The gated pairs' horizontal coordinates in cells, in flat arrays so that the voting loop
// is a few multiply-adds; the grid's offset (half cells) is folded into the target's.
struct VotePoints {
    std::vector<float> sx, sy, tx, ty;
};

VotePoints vote_points(const Correspondences& gated, const GroundPoints& s, const GroundPoints& t,
                       int half, double cell_m) {
    const std::size_t n_gated = gated.size();
    VotePoints v;
    v.sx.resize(n_gated);
    v.sy.resize(n_gated);
    v.tx.resize(n_gated);
    v.ty.resize(n_gated);
    const double inv_cell = 1.0 / cell_m;
    for (std::size_t g = 0; g < n_gated; ++g) {
        v.sx[g] = static_cast<float>(s.q[gated[g].source].x() * inv_cell);
        v.sy[g] = static_cast<float>(s.q[gated[g].source].y() * inv_cell);
        v.tx[g] = static_cast<float>(t.q[gated[g].target].x() * inv_cell + half);
        v.ty[g] = static_cast<float>(t.q[gated[g].target].y() * inv_cell + half);
    }
    return v;
}

// One vote per gated pair for the cell of t - R(yaw) s on a grid of side x side cells; the
// cells that had none before are appended to `touched`.
void cast_votes(const VotePoints& v, float cos_yaw, float sin_yaw, int side, std::uint16_t* grid,
                std::vector<std::uint32_t>* touched) {
    const float max_index = static_cast<float>(side - 1);
    for (std::size_t g = 0; g < v.sx.size(); ++g) {
        const float x = v.tx[g] - (cos_yaw * v.sx[g] - sin_yaw * v.sy[g]);
        const float y = v.ty[g] - (sin_yaw * v.sx[g] + cos_yaw * v.sy[g]);
        // Inside [0, side - 1): truncation is floor there.
        if (!(x >= 0.0f && y >= 0.0f && x < max_index && y < max_index)) continue;
        const std::uint32_t cell =
            static_cast<std::uint32_t>(y) * side + static_cast<std::uint32_t>(x);
        if (grid[cell] == 0) touched->push_back(cell);
        if (grid[cell] < 65535) ++grid[cell];
    }
}

// Best 2x2 sum of the grid (votes min_votes - 1 when none reaches min_votes), its
// translation the block's vote-weighted centre (m). A block whose sum beats `best` has a
// cell holding more than a quarter of it, so only such cells need their four blocks
// examined.
Peak best_block(const std::vector<std::uint16_t>& grid, const std::vector<std::uint32_t>& touched,
                int half, double yaw_deg, const GroundAlignedSearchParams& params) {
    const int side = 2 * half + 1;
    Peak best;
    best.votes = params.min_votes - 1;
    for (std::uint32_t cell : touched) {
        if (4 * static_cast<int>(grid[cell]) <= best.votes) continue;
        const int ix = static_cast<int>(cell % side);
        const int iy = static_cast<int>(cell / side);
        for (int oy = -1; oy <= 0; ++oy) {
            for (int ox = -1; ox <= 0; ++ox) {
                const int x0 = ix + ox;
                const int y0 = iy + oy;
                if (x0 < 0 || y0 < 0 || x0 + 1 >= side || y0 + 1 >= side) continue;
                const std::size_t base = static_cast<std::size_t>(y0) * side + x0;
                const int v00 = grid[base], v10 = grid[base + 1], v01 = grid[base + side],
                          v11 = grid[base + side + 1];
                const int sum = v00 + v10 + v01 + v11;
                if (sum <= best.votes) continue;
                best.votes = sum;
                best.yaw_deg = yaw_deg;
                const double cx = (v10 + v11) / static_cast<double>(sum);
                const double cy = (v01 + v11) / static_cast<double>(sum);
                best.t = Eigen::Vector2d((x0 - half + 0.5 + cx) * params.cell_m,
                                         (y0 - half + 0.5 + cy) * params.cell_m);
            }
        }
    }
    return best;
}

// Per yaw step, the best translation by votes on a square grid centred on t = 0, when it
// has at least min_votes. Only touched cells are cleared between the yaws.
std::vector<Peak> vote_peaks(const Correspondences& gated, const GroundPoints& s,
                             const GroundPoints& t, const GroundAlignedSearchParams& params) {
    const int half = static_cast<int>(std::ceil(params.max_translation_m / params.cell_m));
    const int side = 2 * half + 1;
    const VotePoints points = vote_points(gated, s, t, half, params.cell_m);
    std::vector<std::uint16_t> grid(static_cast<std::size_t>(side) * side, 0);
    std::vector<std::uint32_t> touched;
    std::vector<Peak> peaks;
    const int yaw_steps = std::max(1, static_cast<int>(std::lround(360.0 / params.yaw_step_deg)));
    for (int step = 0; step < yaw_steps; ++step) {
        const double yaw_deg = step * 360.0 / yaw_steps;
        const auto cos_yaw = static_cast<float>(std::cos(yaw_deg * kDegToRad));
        const auto sin_yaw = static_cast<float>(std::sin(yaw_deg * kDegToRad));
        touched.clear();
        cast_votes(points, cos_yaw, sin_yaw, side, grid.data(), &touched);
        const Peak best = best_block(grid, touched, half, yaw_deg, params);
        for (std::uint32_t cell : touched) grid[cell] = 0;
        if (best.votes >= params.min_votes) peaks.push_back(best);
    }
    return peaks;
}

// Strongest first, then non-maximum suppression over yaw and translation, at most
// max_peaks.
std::vector<Peak> strongest_distinct(std::vector<Peak> peaks,
                                     const GroundAlignedSearchParams& params) {
    std::stable_sort(peaks.begin(), peaks.end(),
                     [](const Peak& a, const Peak& b) { return a.votes > b.votes; });
    std::vector<Peak> kept;
    for (const Peak& p : peaks) {
        if (static_cast<int>(kept.size()) >= params.max_peaks) break;
        bool suppressed = false;
        for (const Peak& k : kept) {
            double dyaw = std::abs(p.yaw_deg - k.yaw_deg);
            dyaw = std::min(dyaw, 360.0 - dyaw);
            if (dyaw < params.nms_yaw_deg && (p.t - k.t).norm() < params.nms_translation_m)
                suppressed = true;
        }
        if (!suppressed) kept.push_back(p);
    }
    return kept;
}

// A candidate per peak: its transform in the sensor frames and the gated pairs it brings
// within inlier_distance_m.
std::vector<GroundAlignedCandidate> candidates_from(const std::vector<Peak>& peaks,
                                                    const Correspondences& gated,
                                                    const GroundPoints& s, const GroundPoints& t,
                                                    const GroundAlignedKeypoints& source,
                                                    const GroundAlignedKeypoints& target,
                                                    const GroundAlignedSearchParams& params) {
    std::vector<GroundAlignedCandidate> out;
    const double inlier_sq = params.inlier_distance_m * params.inlier_distance_m;
    for (const Peak& p : peaks) {
        GroundAlignedCandidate candidate;
        candidate.yaw_deg = p.yaw_deg;
        candidate.translation_m = p.t;
        candidate.votes = p.votes;
        Eigen::Isometry3d T_gt_gs =
            Eigen::Isometry3d::Identity();  // source ground -> target ground
        T_gt_gs.linear() =
            Eigen::AngleAxisd(p.yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        T_gt_gs.translation() = Eigen::Vector3d(p.t.x(), p.t.y(), 0.0);
        for (const Correspondence& g : gated) {
            if ((T_gt_gs * s.q[g.source] - t.q[g.target]).squaredNorm() <= inlier_sq)
                candidate.inliers.push_back(g);
        }
        candidate.T_target_source =
            target.T_ground_sensor.inverse() * T_gt_gs * source.T_ground_sensor;
        out.push_back(std::move(candidate));
    }
    return out;
}

}  // namespace

std::vector<GroundAlignedCandidate> ground_aligned_search(const GroundAlignedKeypoints& source,
                                                          const GroundAlignedKeypoints& target,
                                                          const GroundAlignedSearchParams& params) {
    if (!inputs_usable(source, target, params)) return {};
    const GroundPoints s = to_ground(source);
    const GroundPoints t = to_ground(target);
    const Correspondences gated = gate_correspondences(source, target, s, t, params);
    if (gated.size() < 3) return {};
    const std::vector<Peak> peaks = strongest_distinct(vote_peaks(gated, s, t, params), params);
    return candidates_from(peaks, gated, s, t, source, target, params);
}

}  // namespace lidarfuse::core
