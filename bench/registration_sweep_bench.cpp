// Robustness of the initial registration (issue 4) on the synthetic street scene
// (tests/core/synthetic_lidar_scene.hpp), two sensors, no initial guess:
//   1. versus relative yaw: the source sensor (at street pose 2, tilted 10 deg down) is
//      turned about the vertical in `yaw_step` steps over 0-360 deg;
//   2. versus field-of-view overlap: the source keeps only a 90-deg (`fov`) azimuth sector
//      of its scan, centred at 0, 45, ..., 315 deg; the measured overlap share (source
//      points within 0.5 m of a target point under the true transform) is printed with
//      each result.
// Success = the source registered within 3 cm / 0.1 deg of the truth; "wrong" = registered
// beyond that (must stay 0). Each configuration runs with `seeds` noise seeds.
// Prints `name value unit` lines.
//
// Usage: registration_sweep_bench [seeds=2] [yaw_step=30] [fov=90] [threads=2]
// Environment (for comparisons): SWEEP_ONLY_FOV=1 skips the yaw sweep;
// SWEEP_MAX_FREE_SPACE=x sets max_free_space_violation_share; SWEEP_NO_GROUND_SEARCH=1
// runs the paper's FPFH + RANSAC candidates only; SWEEP_NO_AMBIGUITY=1 turns the
// consensus's ambiguity test off (edge_consensus.hpp: the old guess by p2p support);
// SWEEP_MIN_BRIDGE_INFO=x sets consensus.min_bridge_information_per_inlier (0: the weak-bridge test
// off). Per-run errors go to stderr; SWEEP_VERBOSE=1 adds every candidate register_pair tried, with
// its error against the truth and the check that dropped it.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/common/kdtree.hpp"
#include "core/common/se3.hpp"
#include "core/initial/initial_registration.hpp"
#include "tests/core/synthetic_lidar_scene.hpp"

using namespace lidarfuse;

namespace {

struct Outcome {
    bool success = false;
    bool wrong = false;
    double overlap_share = 0.0;
};

double overlap_share(const core::PointCloud& source, const core::PointCloud& target,
                     const Eigen::Isometry3d& T_target_source) {
    if (source.size() == 0 || target.size() == 0) return 0.0;
    const core::KdTree tree(target.points);
    std::size_t near = 0;
    for (const auto& p : source.points) {
        std::uint32_t index = 0;
        double d2 = 0.0;
        if (tree.nearest(T_target_source * p, &index, &d2) && d2 <= 0.25) ++near;
    }
    return static_cast<double>(near) / static_cast<double>(source.size());
}

// Keeps the points whose azimuth (sensor frame) lies within fov_deg / 2 of centre_deg.
core::PointCloud azimuth_sector(const core::PointCloud& cloud, double centre_deg, double fov_deg) {
    core::PointCloud out;
    for (const auto& p : cloud.points) {
        double d = std::atan2(p.y(), p.x()) * 180.0 / M_PI - centre_deg;
        d = std::remainder(d, 360.0);
        if (std::abs(d) <= 0.5 * fov_deg) out.points.push_back(p);
    }
    return out;
}

Outcome run(const core::PointCloud& target, const core::PointCloud& source,
            const Eigen::Isometry3d& truth, int threads) {
    core::InitialRegistrationParams params = core::default_initial_registration_params();
    if (const char* fs = std::getenv("SWEEP_MAX_FREE_SPACE"))
        params.pair.max_free_space_violation_share = std::atof(fs);
    if (std::getenv("SWEEP_NO_GROUND_SEARCH")) params.pair.use_ground_aligned_search = false;
    if (std::getenv("SWEEP_NO_AMBIGUITY")) params.consensus.ambiguity.enabled = false;
    if (const char* b = std::getenv("SWEEP_MIN_BRIDGE_INFO"))
        params.consensus.min_bridge_information_per_inlier = std::atof(b);
    const auto result = core::register_initial({target, source}, params, threads);
    Outcome o;
    o.overlap_share = overlap_share(source, target, truth);
    const auto& s = result.sensors[1];
    if (s.registered) {
        const bool close = core::translation_error_m(s.T_root_sensor, truth) <= 0.03 &&
                           core::rotation_error_deg(s.T_root_sensor, truth) <= 0.1;
        o.success = close;
        o.wrong = !close;
        std::fprintf(stderr,
                     "  registered: error %.3f m %.3f deg (free-space violations %.3f, overlap "
                     "%.2f, alternatives %zu)\n",
                     core::translation_error_m(s.T_root_sensor, truth),
                     core::rotation_error_deg(s.T_root_sensor, truth),
                     result.pairs[0].chosen.free_space_violation_share,
                     result.pairs[0].chosen.overlap_share, result.pairs[0].alternatives.size());
    } else {
        std::fprintf(stderr, "  not registered: %s\n", core::to_string(s.status));
    }
    if (std::getenv("SWEEP_VERBOSE")) {
        const core::PairResult& p = result.pairs[0];
        std::fprintf(stderr, "    pair: %s, chosen candidate %d, %zu alternatives\n",
                     core::to_string(p.status), p.chosen.candidate, p.alternatives.size());
        for (const core::CandidateRecord& r : p.tried) {
            std::fprintf(stderr,
                         "    cand %2d %s support %3zu: %-20s init %6.2f m %6.1f deg -> %6.2f m "
                         "%7.2f deg | coarse_fs "
                         "%.3f gicp_inl %.3f info/inl %.2f p2p %.3f m overlap %.3f fs %.3f\n",
                         r.candidate, r.ground_search ? "G" : "R", r.support,
                         core::to_string(r.outcome), core::translation_error_m(r.T_initial, truth),
                         core::rotation_error_deg(r.T_initial, truth),
                         core::translation_error_m(r.T_refined, truth),
                         core::rotation_error_deg(r.T_refined, truth), r.coarse_free_space_share,
                         r.gicp_inlier_ratio, r.information_per_inlier, r.p2p_error_m,
                         r.overlap_share, r.free_space_share);
        }
    }
    return o;
}

}  // namespace

int main(int argc, char** argv) {
    const int seeds = argc > 1 ? std::atoi(argv[1]) : 2;
    const int yaw_step = argc > 2 ? std::max(1, std::atoi(argv[2])) : 30;
    const double fov_deg = argc > 3 ? std::atof(argv[3]) : 90.0;
    const int threads = argc > 4 ? std::atoi(argv[4]) : 2;

    const testing::Scene scene = testing::street_scene();
    testing::ScanPattern pattern;
    pattern.columns = 1024;
    pattern.range_noise_sigma_m = 0.03;  // 3 sigma = 10 cm, as in the paper's simulation
    const Eigen::Isometry3d T_world_target = testing::street_sensor_poses()[0];

    const bool only_fov = std::getenv("SWEEP_ONLY_FOV") != nullptr;
    // 1. Relative yaw.
    int yaw_runs = 0, yaw_success = 0, yaw_wrong = 0;
    for (int yaw = 0; yaw < (only_fov ? 0 : 360); yaw += yaw_step) {
        int ok = 0;
        for (int seed = 1; seed <= seeds; ++seed) {
            const Eigen::Isometry3d T_world_source =
                testing::sensor_pose(-11.0, -2.0, 5.5, yaw, 10.0);
            const core::PointCloud target =
                testing::scan_scene(scene, T_world_target, pattern, 100 + seed);
            const core::PointCloud source =
                testing::scan_scene(scene, T_world_source, pattern, 200 + seed);
            const Outcome o =
                run(target, source, T_world_target.inverse() * T_world_source, threads);
            ++yaw_runs;
            ok += o.success ? 1 : 0;
            yaw_wrong += o.wrong ? 1 : 0;
        }
        yaw_success += ok;
        std::printf("sweep_yaw_%03d_success_rate %.0f %%\n", yaw, 100.0 * ok / seeds);
    }
    std::printf("sweep_yaw_success_rate %.1f %%\n", 100.0 * yaw_success / std::max(1, yaw_runs));
    std::printf("sweep_yaw_wrong_poses %d poses\n", yaw_wrong);
    std::printf("sweep_yaw_refused %d runs\n", yaw_runs - yaw_success - yaw_wrong);

    // 2. Field-of-view overlap.
    const Eigen::Isometry3d T_world_source = testing::street_sensor_poses()[2];
    const Eigen::Isometry3d truth = T_world_target.inverse() * T_world_source;
    int fov_runs = 0, fov_success = 0, fov_wrong = 0;
    for (int centre = 0; centre < 360; centre += 45) {
        int ok = 0;
        double overlap = 0.0;
        for (int seed = 1; seed <= seeds; ++seed) {
            const core::PointCloud target =
                testing::scan_scene(scene, T_world_target, pattern, 100 + seed);
            const core::PointCloud source = azimuth_sector(
                testing::scan_scene(scene, T_world_source, pattern, 200 + seed), centre, fov_deg);
            const Outcome o = run(target, source, truth, threads);
            ++fov_runs;
            ok += o.success ? 1 : 0;
            fov_wrong += o.wrong ? 1 : 0;
            overlap += o.overlap_share / seeds;
        }
        fov_success += ok;
        std::printf("sweep_fov_sector_%03d_overlap_share %.3f share\n", centre, overlap);
        std::printf("sweep_fov_sector_%03d_success_rate %.0f %%\n", centre, 100.0 * ok / seeds);
    }
    std::printf("sweep_fov_success_rate %.1f %%\n", 100.0 * fov_success / std::max(1, fov_runs));
    std::printf("sweep_fov_wrong_poses %d poses\n", fov_wrong);
    std::printf("sweep_fov_refused %d runs\n", fov_runs - fov_success - fov_wrong);
    return 0;
}
