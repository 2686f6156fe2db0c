#include "core/registration/p2p_error.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace lidarfuse::core {

P2pErrorResult p2p_error(const std::vector<Eigen::Vector3d>& source_points,
                         const KdTree& target_tree, const Eigen::Isometry3d& T_target_source,
                         const P2pErrorParams& params, int num_threads) {
    P2pErrorResult result;
    result.num_source = source_points.size();
    if (source_points.empty() || target_tree.size() == 0) return result;
    const double rc2 = params.cutoff_radius_m * params.cutoff_radius_m;
    // nearest_within() finds points strictly closer than its bound: d2 < next(rc2) <=> d2 <= rc2.
    const double bound = std::nextafter(rc2, std::numeric_limits<double>::infinity());
    const int threads = std::max(1, num_threads);
    // Per-thread partial sums, added in thread order (deterministic for a thread count).
    std::vector<double> partial_sum(static_cast<std::size_t>(threads), 0.0);
    std::vector<std::size_t> partial_count(static_cast<std::size_t>(threads), 0);
    const long long count = static_cast<long long>(source_points.size());
#pragma omp parallel num_threads(threads) if (threads > 1)
    {
        double sum = 0.0;
        std::size_t within = 0;
#pragma omp for schedule(static)
        for (long long i = 0; i < count; ++i) {
            const Eigen::Vector3d u = T_target_source * source_points[i];
            std::uint32_t j = 0;
            double d2 = 0.0;
            // Only neighbors within the cutoff count, so the search needs to look no
            // farther (bounded: much faster for the points a wrong candidate throws away).
            if (!u.allFinite() || !target_tree.nearest_within(u, bound, &j, &d2)) continue;
            sum += d2;  // d2 <= rc2: w_i = 1
            ++within;
        }
        const auto tid = static_cast<std::size_t>(omp_get_thread_num());
        partial_sum[tid] = sum;
        partial_count[tid] = within;
    }
    double sum = 0.0;
    for (int t = 0; t < threads; ++t) {
        sum += partial_sum[static_cast<std::size_t>(t)];
        result.num_within_cutoff += partial_count[static_cast<std::size_t>(t)];
    }
    result.overlap_share =
        static_cast<double>(result.num_within_cutoff) / static_cast<double>(result.num_source);
    if (result.num_within_cutoff > 0) {
        result.valid = true;
        result.error_m = std::sqrt(sum / static_cast<double>(result.num_within_cutoff));
    }
    return result;
}

}  // namespace lidarfuse::core
