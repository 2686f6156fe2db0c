#include "bench/registration_diagnose_stages.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "core/common/kdtree.hpp"
#include "core/common/se3.hpp"
#include "core/common/stopwatch.hpp"

namespace lidarfuse::bench {

namespace {

// register_pair's G-ICP runs, one per correspondence bound, each from the last result.
core::GicpResult coarse_to_fine(const core::PairRegistrationParams& p,
                                const core::GicpCloud& target, const core::GicpCloud& source,
                                const Eigen::Isometry3d& T_start) {
    core::GicpParams gparams = p.gicp;
    core::GicpRegistration reg(gparams);
    core::GicpResult result;
    result.T_target_source = T_start;
    for (double bound_m : p.gicp_max_correspondence_m) {
        gparams.max_correspondence_distance_m = bound_m;
        reg.set_params(gparams);
        result = reg.align(target, source, result.T_target_source);
    }
    return result;
}

core::P2pErrorResult p2p_at(const core::SensorFeatures& src, const core::SensorFeatures& tgt,
                            const Eigen::Isometry3d& T, const core::PairRegistrationParams& p) {
    core::P2pErrorParams pp;
    pp.cutoff_radius_m = p.p2p_cutoff_m;
    return core::p2p_error(src.gicp.cloud().points, tgt.gicp.tree(), T, pp);
}

// Repeatability: source keypoints that land near a target keypoint, among those that land
// near the target's octree cloud (in the overlap).
std::pair<int, int> keypoint_repeatability(const core::SensorFeatures& src,
                                           const core::SensorFeatures& tgt,
                                           const Eigen::Isometry3d& T, double threshold_m) {
    const core::KdTree kp_tree(tgt.keypoint_points);
    const core::KdTree cloud_tree(tgt.octree.cloud.points);
    int in_overlap = 0, repeated = 0;
    for (const auto& q : src.keypoint_points) {
        std::uint32_t idx = 0;
        double d2 = 0.0;
        const Eigen::Vector3d m = T * q;
        if (!cloud_tree.nearest(m, &idx, &d2) || d2 > 0.25) continue;
        ++in_overlap;
        if (kp_tree.nearest(m, &idx, &d2) && d2 <= threshold_m * threshold_m) ++repeated;
    }
    return {in_overlap, repeated};
}

// Descriptor quality: the rank of the true partner among all target descriptors (0 = best),
// as a share of the target's keypoints, for every source keypoint that has one.
std::vector<double> true_partner_ranks(const core::SensorFeatures& src,
                                       const core::SensorFeatures& tgt, const Eigen::Isometry3d& T,
                                       double threshold_m) {
    std::vector<double> ranks;
    for (std::size_t a = 0; a < src.keypoint_points.size(); ++a) {
        const Eigen::Vector3d m = T * src.keypoint_points[a];
        std::vector<std::pair<float, bool>> d;
        bool any = false;
        for (std::size_t b = 0; b < tgt.keypoint_points.size(); ++b) {
            const bool ok = (m - tgt.keypoint_points[b]).norm() <= threshold_m;
            any = any || ok;
            d.emplace_back((src.descriptors[a] - tgt.descriptors[b]).norm(), ok);
        }
        if (!any) continue;
        std::sort(d.begin(), d.end());
        for (std::size_t b = 0; b < d.size(); ++b) {
            if (d[b].second) {
                ranks.push_back(static_cast<double>(b) / d.size());
                break;
            }
        }
    }
    std::sort(ranks.begin(), ranks.end());
    return ranks;
}

// Keypoints, repeatability, matches (true ones within the RANSAC threshold) and ranks.
core::Correspondences report_matches(const core::SensorFeatures& src,
                                     const core::SensorFeatures& tgt, std::size_t i, std::size_t j,
                                     const Eigen::Isometry3d& T,
                                     const core::PairRegistrationParams& p) {
    const double threshold_m = p.ransac.inlier_threshold_m;
    const auto [in_overlap, repeated] = keypoint_repeatability(src, tgt, T, threshold_m);
    const core::Correspondences matches =
        core::match_features(src.descriptors, tgt.descriptors, p.matching);
    int true_matches = 0;
    for (const auto& c : matches) {
        if ((T * src.keypoint_points[c.source] - tgt.keypoint_points[c.target]).norm() <=
            threshold_m) {
            ++true_matches;
        }
    }
    const std::vector<double> ranks = true_partner_ranks(src, tgt, T, threshold_m);
    if (!ranks.empty()) {
        std::fprintf(stderr, "  ranks %zu->%zu: n %zu p25 %.3f p50 %.3f p75 %.3f p90 %.3f\n", i, j,
                     ranks.size(), ranks[ranks.size() / 4], ranks[ranks.size() / 2],
                     ranks[ranks.size() * 3 / 4], ranks[ranks.size() * 9 / 10]);
    }
    std::fprintf(stderr,
                 "  pair %zu->%zu: kp %zu/%zu in_overlap %d repeatable %d matches %zu "
                 "true %d (%.3f)\n",
                 i, j, src.keypoints.size(), tgt.keypoints.size(), in_overlap, repeated,
                 matches.size(), true_matches,
                 matches.empty() ? 0.0 : static_cast<double>(true_matches) / matches.size());
    return matches;
}

// The checks at the truth: what the free-space test and G-ICP say of the right transform
// (a right pair refused by a check shows here).
void report_truth_checks(const core::SensorFeatures& src, const core::SensorFeatures& tgt,
                         const Eigen::Isometry3d& T, const core::PairRegistrationParams& p) {
    const auto a = core::free_space_violations(src.gicp.cloud().points, tgt.free_space, T);
    const auto b =
        core::free_space_violations(tgt.gicp.cloud().points, src.free_space, T.inverse());
    std::fprintf(stderr,
                 "    truth free space: source->target %zu/%zu %.3f  "
                 "target->source %zu/%zu %.3f\n",
                 a.num_violations, a.num_tested, a.violation_share, b.num_violations, b.num_tested,
                 b.violation_share);
    const core::GicpResult gr = coarse_to_fine(p, tgt.gicp, src.gicp, T);
    const Eigen::Isometry3d Tc = gr.T_target_source;
    const auto pe = p2p_at(src, tgt, Tc, p);
    std::fprintf(stderr,
                 "    G-ICP from the truth: moves %.3f m %.3f deg, converged %d in %d, "
                 "inliers %.3f, "
                 "p2p %.3f m, overlap %.3f, info/inlier %.2f\n",
                 core::translation_error_m(Tc, T), core::rotation_error_deg(Tc, T),
                 gr.converged ? 1 : 0, gr.iterations, gr.inlier_ratio, pe.error_m, pe.overlap_share,
                 core::information_per_inlier(gr.H_eigenvalues(0), gr.num_inliers));
}

// Each ground-aligned peak that passes the coarse free-space check, refined as
// register_pair refines it, with the checks' figures against the truth.
void refine_peaks(const core::SensorFeatures& src, const core::SensorFeatures& tgt, std::size_t i,
                  std::size_t j, const Eigen::Isometry3d& T, const core::PairRegistrationParams& p,
                  const std::vector<core::GroundAlignedCandidate>& peaks) {
    for (const auto& c : peaks) {
        const auto coarse = core::free_space_violations_both(
            src.gicp.cloud().points, src.free_space, tgt.gicp.cloud().points, tgt.free_space,
            c.T_target_source);
        if (coarse.violation_share > p.max_ground_coarse_free_space_violation_share) continue;
        const core::GicpResult gr = coarse_to_fine(p, tgt.gicp, src.gicp, c.T_target_source);
        const Eigen::Isometry3d Tc = gr.T_target_source;
        const auto fs = core::free_space_violations_both(
            src.gicp.cloud().points, src.free_space, tgt.gicp.cloud().points, tgt.free_space, Tc);
        const auto pe = p2p_at(src, tgt, Tc, p);
        std::fprintf(stderr,
                     "    refined %zu->%zu: start %.2fm err %.3fm %.3fdeg "
                     "fs %.4f coarse %.3f p2p %.3f N %zu inl %.2f it %d\n",
                     i, j, core::translation_error_m(c.T_target_source, T),
                     core::translation_error_m(Tc, T), core::rotation_error_deg(Tc, T),
                     fs.violation_share, coarse.violation_share, pe.error_m, pe.num_within_cutoff,
                     gr.inlier_ratio, gr.iterations);
    }
}

// The ground-aligned search's peaks, with their free-space share and errors.
void report_ground_search(const core::SensorFeatures& src, const core::SensorFeatures& tgt,
                          std::size_t i, std::size_t j, const Eigen::Isometry3d& T,
                          const core::PairRegistrationParams& p, const StageOptions& options) {
    const core::GroundAlignedKeypoints ks{&src.keypoint_points, &src.keypoint_normals,
                                          &src.descriptors, src.ground.T_ground_sensor};
    const core::GroundAlignedKeypoints kt{&tgt.keypoint_points, &tgt.keypoint_normals,
                                          &tgt.descriptors, tgt.ground.T_ground_sensor};
    const core::Stopwatch search_time;
    const auto peaks = core::ground_aligned_search(ks, kt, options.ground_search);
    const double dt = search_time.seconds();
    if (options.refine_peaks) refine_peaks(src, tgt, i, j, T, p, peaks);
    std::fprintf(stderr, "    ground search %.1f ms:", dt * 1e3);
    for (const auto& c : peaks) {
        const auto fs = core::free_space_violations_both(src.gicp.cloud().points, src.free_space,
                                                         tgt.gicp.cloud().points, tgt.free_space,
                                                         c.T_target_source);
        std::fprintf(stderr, " [v%d i%zu fs%.3f %.2fm %.2fdeg]", c.votes, c.inliers.size(),
                     fs.violation_share, core::translation_error_m(c.T_target_source, T),
                     core::rotation_error_deg(c.T_target_source, T));
    }
    std::fprintf(stderr, "\n");
}

// RANSAC's rounds as register_pair runs them: each on the matches earlier rounds left.
void report_ransac_rounds(const core::SensorFeatures& src, const core::SensorFeatures& tgt,
                          const Eigen::Isometry3d& T, const core::PairRegistrationParams& p,
                          core::Correspondences remaining) {
    for (int round = 0; round < p.max_candidates && remaining.size() >= 3; ++round) {
        core::RansacParams rp = p.ransac;
        rp.seed = p.ransac.seed + static_cast<std::uint32_t>(round);
        const auto r =
            core::ransac_registration(src.keypoint_points, tgt.keypoint_points, remaining, rp);
        if (!r.success) break;
        std::fprintf(stderr, "    round %d: inliers %zu iterations %d err %.2f m %.2f deg\n", round,
                     r.inliers.size(), r.iterations,
                     core::translation_error_m(r.T_target_source, T),
                     core::rotation_error_deg(r.T_target_source, T));
        std::vector<bool> used(remaining.size(), false);
        for (auto k : r.inliers) used[k] = true;
        core::Correspondences next;
        for (std::size_t k = 0; k < remaining.size(); ++k) {
            if (!used[k]) next.push_back(remaining[k]);
        }
        remaining.swap(next);
    }
}

}  // namespace

std::vector<core::SensorFeatures> diagnose_features(const std::string& dir,
                                                    const DiagnoseFrame& frame,
                                                    const core::InitialRegistrationParams& params,
                                                    int threads) {
    std::vector<core::SensorFeatures> features;
    for (std::size_t i = 0; i < frame.clouds.size(); ++i) {
        features.push_back(core::compute_sensor_features(frame.clouds[i], params.features,
                                                         params.min_keypoints, threads));
        const core::SensorFeatures& f = features[i];
        const auto& g = f.ground;
        const Eigen::Vector3d up_true =
            frame.T_world_sensor[i].linear().transpose() * Eigen::Vector3d::UnitZ();
        std::fprintf(stderr,
                     "%s %s: points %zu pre %zu octree %zu keypoints %zu status %s ground %d "
                     "h %.3f (true %.3f) up_err %.3f deg inl %zu\n",
                     dir.c_str(), frame.names[i].c_str(), f.num_input_points,
                     f.num_preprocessed_points, f.octree.cloud.size(), f.keypoints.size(),
                     core::to_string(f.status), g.found ? 1 : 0, g.sensor_height_m,
                     frame.T_world_sensor[i].translation().z(),
                     std::acos(std::min(1.0, g.up.dot(up_true))) * 180 / M_PI, g.num_inliers);
    }
    return features;
}

void diagnose_pair(const core::SensorFeatures& source, const core::SensorFeatures& target,
                   std::size_t i, std::size_t j, const Eigen::Isometry3d& T_truth,
                   const core::PairRegistrationParams& p, const StageOptions& options) {
    if (source.keypoint_points.empty() || target.keypoint_points.empty()) return;
    const core::Correspondences matches = report_matches(source, target, i, j, T_truth, p);
    report_truth_checks(source, target, T_truth, p);
    report_ground_search(source, target, i, j, T_truth, p, options);
    if (!options.match_only) report_ransac_rounds(source, target, T_truth, p, matches);
}

}  // namespace lidarfuse::bench
