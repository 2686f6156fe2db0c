#include "core/initial/edge_polish.hpp"

#include <algorithm>
#include <cstdint>

#include "core/common/se3.hpp"
#include "core/registration/information.hpp"
#include "core/registration/p2p_error.hpp"
#include "core/registration/ransac.hpp"

namespace lidarfuse::core {

namespace {

// The tight runs from the chosen transform; false when any run fails or a limit is broken.
bool polish_one(const SensorFeatures& source, const SensorFeatures& target,
                const EdgePolishParams& params, PairResult* pair) {
    const GicpCloud& target_cloud = target.polish.empty() ? target.gicp : target.polish;
    const GicpCloud& source_cloud = source.polish.empty() ? source.gicp : source.polish;
    GicpParams gicp_params = params.gicp;
    GicpRegistration gicp(gicp_params);  // one thread: the edges run in parallel
    Eigen::Isometry3d T = pair->chosen.T_target_source;
    GicpResult run;
    for (const double bound : params.max_correspondence_m) {
        gicp_params.max_correspondence_distance_m = bound;
        gicp.set_params(gicp_params);
        run = gicp.align(target_cloud, source_cloud, T);
        if (!run.converged && run.status != GicpStatus::kMaxIterations) return false;
        T = run.T_target_source;
    }
    if (!keeps_up_vector(T, up_direction(source), up_direction(target)) ||
        run.inlier_ratio < params.min_overlap_share)
        return false;
    if (translation_error_m(T, pair->chosen.T_target_source) > params.max_shift_m ||
        rotation_error_deg(T, pair->chosen.T_target_source) > params.max_rotation_deg) {
        return false;
    }
    if (!usable_information(run.H)) return false;
    P2pErrorParams p2p_params;
    p2p_params.cutoff_radius_m = params.p2p_cutoff_m;
    const P2pErrorResult p2p =
        p2p_error(source.gicp.cloud().points, target.gicp.tree(), T, p2p_params);
    if (!p2p.valid) return false;

    pair->chosen.T_target_source = T;
    pair->chosen.information = run.H;
    pair->chosen.gicp_inliers = run.num_inliers;
    pair->chosen.min_hessian_eigenvalue = run.H_eigenvalues(0);
    pair->chosen.min_translation_hessian_eigenvalue = run.H_translation_eigenvalues(0);
    pair->chosen.p2p_error_m = p2p.error_m;
    pair->chosen.p2p_inliers = p2p.num_within_cutoff;
    pair->chosen.overlap_share = p2p.overlap_share;
    pair->polished = true;
    return true;
}

}  // namespace

EdgePolishSummary polish_edges(const std::vector<SensorFeatures>& features,
                               const std::vector<bool>& edge_ok, const EdgePolishParams& params,
                               std::vector<PairResult>* pairs, int num_threads) {
    EdgePolishSummary summary;
    if (params.max_correspondence_m.empty()) return summary;
    std::vector<std::size_t> edges;
    for (std::size_t e = 0; e < pairs->size(); ++e) {
        if (edge_ok[e]) edges.push_back(e);
    }
    std::vector<char> polished(edges.size(), 0);
    const auto count = static_cast<std::int64_t>(edges.size());
#pragma omp parallel for num_threads(std::max(1, num_threads)) if (num_threads > 1) \
    schedule(dynamic, 1)
    for (std::int64_t k = 0; k < count; ++k) {
        PairResult& pair = (*pairs)[edges[k]];
        polished[k] =
            polish_one(features[pair.source], features[pair.target], params, &pair) ? 1 : 0;
    }
    for (const char p : polished) {
        if (p) {
            ++summary.polished;
        } else {
            ++summary.kept;
        }
    }
    return summary;
}

}  // namespace lidarfuse::core
