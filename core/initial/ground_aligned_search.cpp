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

// Keypoints in the ground frame, and each one's normal angle to the vertical (deg).
void to_ground(const GroundAlignedKeypoints& k, std::vector<Eigen::Vector3d>* q,
               std::vector<double>* tilt) {
    const std::size_t n = k.points->size();
    q->resize(n);
    tilt->resize(n);
    const Eigen::Matrix3d R = k.T_ground_sensor.linear();
    for (std::size_t i = 0; i < n; ++i) {
        (*q)[i] = k.T_ground_sensor * (*k.points)[i];
        const double nz = std::abs((R * (*k.normals)[i]).z());
        (*tilt)[i] = std::acos(std::min(1.0, nz)) / kDegToRad;
    }
}

}  // namespace

std::vector<GroundAlignedCandidate> ground_aligned_search(const GroundAlignedKeypoints& source,
                                                          const GroundAlignedKeypoints& target,
                                                          const GroundAlignedSearchParams& params) {
    std::vector<GroundAlignedCandidate> out;
    if (source.points == nullptr || target.points == nullptr || source.normals == nullptr ||
        target.normals == nullptr || source.descriptors == nullptr ||
        target.descriptors == nullptr) {
        return out;
    }
    const std::size_t ns = source.points->size();
    const std::size_t nt = target.points->size();
    if (ns < 3 || nt < 3 || source.normals->size() != ns || target.normals->size() != nt ||
        source.descriptors->size() != ns || target.descriptors->size() != nt ||
        !(params.cell_m > 0.0) || !(params.yaw_step_deg > 0.0)) {
        return out;
    }
    std::vector<Eigen::Vector3d> qs, qt;
    std::vector<double> tilt_s, tilt_t;
    to_ground(source, &qs, &tilt_s);
    to_ground(target, &qt, &tilt_t);

    // Gate: height, normal tilt, descriptor rank.
    const auto rank_limit = static_cast<std::size_t>(
        std::ceil(std::clamp(params.descriptor_rank_share, 0.0, 1.0) * static_cast<double>(nt)));
    Correspondences gated;
    std::vector<std::pair<float, std::uint32_t>> by_distance(nt);
    const bool rank_gate = rank_limit < nt;
    for (std::size_t a = 0; a < ns; ++a) {
        if (qs[a].z() < params.min_height_m) continue;
        auto geometric_gate = [&](std::size_t b) {
            return qt[b].z() >= params.min_height_m &&
                   std::abs(qs[a].z() - qt[b].z()) <= params.max_height_difference_m &&
                   std::abs(tilt_s[a] - tilt_t[b]) <= params.max_normal_tilt_difference_deg;
        };
        if (!rank_gate) {
            for (std::size_t b = 0; b < nt; ++b) {
                if (geometric_gate(b))
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
            if (geometric_gate(b))
                gated.push_back(
                    {static_cast<std::uint32_t>(a), b, std::sqrt(by_distance[r].first)});
        }
    }
    if (gated.size() < 3) return out;

    // Vote per yaw on a square grid centred on t = 0; only touched cells are cleared. The
    // gated pairs' horizontal coordinates are copied into flat arrays (in cells, with the
    // grid offset folded into the target's) so the inner loop is a few multiply-adds.
    const int half = static_cast<int>(std::ceil(params.max_translation_m / params.cell_m));
    const int side = 2 * half + 1;
    const std::size_t n_gated = gated.size();
    std::vector<float> sx(n_gated), sy(n_gated), tx(n_gated), ty(n_gated);
    const double inv_cell = 1.0 / params.cell_m;
    for (std::size_t g = 0; g < n_gated; ++g) {
        sx[g] = static_cast<float>(qs[gated[g].source].x() * inv_cell);
        sy[g] = static_cast<float>(qs[gated[g].source].y() * inv_cell);
        tx[g] = static_cast<float>(qt[gated[g].target].x() * inv_cell + half);
        ty[g] = static_cast<float>(qt[gated[g].target].y() * inv_cell + half);
    }
    std::vector<std::uint16_t> grid(static_cast<std::size_t>(side) * side, 0);
    std::vector<std::uint32_t> touched;
    std::vector<Peak> peaks;
    const int yaw_steps = std::max(1, static_cast<int>(std::lround(360.0 / params.yaw_step_deg)));
    const float max_index = static_cast<float>(side - 1);
    for (int step = 0; step < yaw_steps; ++step) {
        const double yaw_deg = step * 360.0 / yaw_steps;
        const auto c = static_cast<float>(std::cos(yaw_deg * kDegToRad));
        const auto s = static_cast<float>(std::sin(yaw_deg * kDegToRad));
        touched.clear();
        for (std::size_t g = 0; g < n_gated; ++g) {
            const float x = tx[g] - (c * sx[g] - s * sy[g]);
            const float y = ty[g] - (s * sx[g] + c * sy[g]);
            // Inside [0, side - 1): truncation is floor there.
            if (!(x >= 0.0f && y >= 0.0f && x < max_index && y < max_index)) continue;
            const std::uint32_t cell =
                static_cast<std::uint32_t>(y) * side + static_cast<std::uint32_t>(x);
            if (grid[cell] == 0) touched.push_back(cell);
            if (grid[cell] < 65535) ++grid[cell];
        }
        // Best 2x2 sum. A block whose sum beats `best` has a cell holding more than a
        // quarter of it, so only such cells need their four blocks examined.
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
                    // Vote-weighted centre of the 2x2 block.
                    const double cx = (v10 + v11) / static_cast<double>(sum);
                    const double cy = (v01 + v11) / static_cast<double>(sum);
                    best.t = Eigen::Vector2d((x0 - half + 0.5 + cx) * params.cell_m,
                                             (y0 - half + 0.5 + cy) * params.cell_m);
                }
            }
        }
        for (std::uint32_t cell : touched) grid[cell] = 0;
        if (best.votes >= params.min_votes) peaks.push_back(best);
    }

    // Strongest first, then non-maximum suppression over yaw and translation.
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

    const double inlier_sq = params.inlier_distance_m * params.inlier_distance_m;
    for (const Peak& p : kept) {
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
            if ((T_gt_gs * qs[g.source] - qt[g.target]).squaredNorm() <= inlier_sq)
                candidate.inliers.push_back(g);
        }
        candidate.T_target_source =
            target.T_ground_sensor.inverse() * T_gt_gs * source.T_ground_sensor;
        out.push_back(std::move(candidate));
    }
    return out;
}

}  // namespace lidarfuse::core
