// Diagnoses the initial registration on simulated captures (`lidarfuse sim` output dirs,
// with ground_truth.csv): for every sensor pair it reports what each stage hands on, judged
// against the truth, so a failure can be traced to the stage that lost it:
//   keypoints (per sensor), keypoint repeatability (source keypoints with a target keypoint
//   within the RANSAC threshold under the true transform), descriptor matches, true matches
//   (within the threshold under the true transform: the inlier count RANSAC could reach at
//   the truth), each RANSAC round's inlier count and error against the truth, and
//   register_pair's chosen result; the ground-aligned search's peaks (ground_aligned_search.hpp)
//   with their errors. Then the full register_initial and its pose errors.
//
// Inputs: a simulated capture folder (station.yaml, capture.pcap, ground_truth.csv), or a
// real rig folder as in ../shared/data/real: one point-cloud file per sensor (NAME.pcd or
// NAME.ply) and references T_ROOT_NAME.txt (4 x 4 row-major, p_root = T * p_name), the
// root being the sensor every reference starts from. A real rig's reference is not ground
// truth (its SOURCES.md says how far off it is): the errors printed are distances from it.
//
// Usage: registration_diagnose_bench DIR... [key=value...]
//   keys: fpfh_radius, sift_scale, sift_contrast, sift_octaves, octree_max, octree_min,
//         normals_k, ratio, mutual, candidates_per_source, ransac_iterations,
//         ransac_threshold, rank_share, height_diff, min_height, peaks (ground-aligned
//         search), threads, quiet (1: only register_initial), match_only (1: no RANSAC
//         rounds, no register_initial), refine (1: refine and check every ground-aligned
//         peak), tried (1: every candidate of register_pair that reached G-ICP, with the
//         check that dropped it), truth_shift_s (truth taken this long after the scan's
//         timestamp; 0.025 = mid-sweep at 20 Hz, see calibrate_command_test),
//         min_bridge_info (EdgeConsensusParams::min_bridge_information_per_inlier),
//         gicp_voxel (SensorFeatureParams::gicp_voxel_size_m), gicp_fine (the last G-ICP
//         correspondence bound, m), polish (EdgePolishParams bounds, m, comma-separated;
//         0: no polish), polish_voxel (SensorFeatureParams::polish_voxel_size_m)
// Prints `name value unit` lines (totals over all dirs) on stdout, details on stderr.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "bench/registration_diagnose_inputs.hpp"
#include "bench/registration_diagnose_stages.hpp"
#include "core/common/se3.hpp"
#include "core/common/stopwatch.hpp"
#include "core/initial/initial_registration.hpp"

using namespace lidarfuse;

namespace {

using Options = std::map<std::string, std::string>;

double option(const Options& opts, const std::string& key, double fallback) {
    const auto it = opts.find(key);
    return it == opts.end() ? fallback : std::atof(it->second.c_str());
}

// "0.3,0.2" -> {0.3, 0.2}; "0" -> {} (values <= 0 are left out).
std::vector<double> list_option(const Options& opts, const std::string& key,
                                const std::vector<double>& fallback) {
    const auto it = opts.find(key);
    if (it == opts.end()) return fallback;
    std::vector<double> out;
    std::size_t begin = 0;
    while (begin <= it->second.size()) {
        const std::size_t end = std::min(it->second.find(',', begin), it->second.size());
        const double v = std::atof(it->second.substr(begin, end - begin).c_str());
        if (v > 0.0) out.push_back(v);
        begin = end + 1;
    }
    return out;
}

// The features' keys (steps 2-4) over the defaults.
void set_feature_options(const Options& opts, core::SensorFeatureParams* f) {
    f->fpfh.radius_m = option(opts, "fpfh_radius", f->fpfh.radius_m);
    f->sift.min_scale_m = option(opts, "sift_scale", f->sift.min_scale_m);
    f->sift.min_contrast = option(opts, "sift_contrast", f->sift.min_contrast);
    f->sift.octaves = static_cast<int>(option(opts, "sift_octaves", f->sift.octaves));
    f->octree.max_voxel_size_m = option(opts, "octree_max", f->octree.max_voxel_size_m);
    f->octree.min_voxel_size_m = option(opts, "octree_min", f->octree.min_voxel_size_m);
    f->normals.k_neighbors = static_cast<int>(option(opts, "normals_k", f->normals.k_neighbors));
    f->gicp_voxel_size_m = option(opts, "gicp_voxel", f->gicp_voxel_size_m);
    f->polish_voxel_size_m = option(opts, "polish_voxel", f->polish_voxel_size_m);
}

// The pairs' keys (steps 5-8) over the defaults.
void set_pair_options(const Options& opts, core::PairRegistrationParams* p) {
    p->matching.ratio = option(opts, "ratio", p->matching.ratio);
    p->matching.mutual = option(opts, "mutual", p->matching.mutual ? 1 : 0) != 0;
    p->matching.candidates_per_source =
        static_cast<int>(option(opts, "candidates_per_source", p->matching.candidates_per_source));
    p->ransac.max_iterations =
        static_cast<int>(option(opts, "ransac_iterations", p->ransac.max_iterations));
    p->ransac.inlier_threshold_m = option(opts, "ransac_threshold", p->ransac.inlier_threshold_m);
    p->max_free_space_violation_share =
        option(opts, "max_free_space", p->max_free_space_violation_share);
    p->gicp_max_correspondence_m.back() =
        option(opts, "gicp_fine", p->gicp_max_correspondence_m.back());
}

core::InitialRegistrationParams registration_params(const Options& opts) {
    core::InitialRegistrationParams params = core::default_initial_registration_params();
    set_feature_options(opts, &params.features);
    set_pair_options(opts, &params.pair);
    params.consensus.min_bridge_information_per_inlier =
        option(opts, "min_bridge_info", params.consensus.min_bridge_information_per_inlier);
    params.polish.max_correspondence_m =
        list_option(opts, "polish", params.polish.max_correspondence_m);
    params.consensus.ambiguity.rival_pair_share =
        option(opts, "rival_share", params.consensus.ambiguity.rival_pair_share);
    params.consensus.moves = option(opts, "moves", params.consensus.moves ? 1 : 0) != 0;
    return params;
}

bench::StageOptions stage_options(const Options& opts) {
    bench::StageOptions o;
    o.ground_search.descriptor_rank_share = option(opts, "rank_share", 1.0);
    o.ground_search.max_height_difference_m = option(opts, "height_diff", 1.0);
    o.ground_search.min_height_m = option(opts, "min_height", o.ground_search.min_height_m);
    o.ground_search.max_peaks = static_cast<int>(option(opts, "peaks", o.ground_search.max_peaks));
    o.refine_peaks = option(opts, "refine", 0) != 0;
    o.match_only = option(opts, "match_only", 0) != 0;
    return o;
}

// Totals over every case folder (the stdout lines).
struct Totals {
    int sensors = 0, registered = 0, wrong = 0;
    double worst_t = 0.0, worst_r = 0.0, register_initial_s = 0.0;
};

// Every pair's result and, with `show_tried`, every candidate that reached G-ICP with the
// check that dropped it, against the truth.
void report_pairs(const core::InitialRegistrationResult& result, const bench::DiagnoseFrame& frame,
                  bool show_tried) {
    for (const auto& pair : result.pairs) {
        const Eigen::Isometry3d T = frame.truth(pair.target, pair.source);
        std::fprintf(stderr,
                     "  result %d->%d: %s ransac_inliers %zu cand %d alt %zu chosen %d err "
                     "%.3f m %.3f deg\n",
                     pair.source, pair.target, core::to_string(pair.status),
                     pair.chosen.ransac_inliers, pair.candidates, pair.alternatives.size(),
                     pair.chosen.candidate,
                     core::translation_error_m(pair.chosen.T_target_source, T),
                     core::rotation_error_deg(pair.chosen.T_target_source, T));
        for (const core::CandidateRecord& r : pair.tried) {
            if (!show_tried || r.gicp_inlier_ratio < 0.0) continue;
            std::fprintf(stderr,
                         "    tried %2d %s: %-20s err %7.3f m %7.2f deg | gicp_inl %.3f "
                         "info/inl %6.2f p2p %.3f m "
                         "overlap %.3f fs %.3f\n",
                         r.candidate, r.ground_search ? "G" : "R", core::to_string(r.outcome),
                         core::translation_error_m(r.T_refined, T),
                         core::rotation_error_deg(r.T_refined, T), r.gicp_inlier_ratio,
                         r.information_per_inlier, r.p2p_error_m, r.overlap_share,
                         r.free_space_share);
        }
    }
}

void report_stage_sums(const core::InitialRegistrationResult& result) {
    const core::StageTimeSums sums = core::sum_stage_timings(result);
    const core::SensorFeatureTimings& ft = sums.features;
    const core::PairTimings& pt = sums.pairs;
    std::fprintf(stderr,
                 "  stage sums ms: preprocess %.0f normals %.0f octree %.0f sift %.0f fpfh "
                 "%.0f ground %.0f "
                 "gicp_cloud %.0f | matching %.0f ground_search %.0f ransac %.0f gicp %.0f "
                 "p2p %.0f\n",
                 1e3 * ft.preprocess_s, 1e3 * ft.normals_s, 1e3 * ft.octree_s, 1e3 * ft.keypoints_s,
                 1e3 * ft.fpfh_s, 1e3 * ft.ground_s, 1e3 * ft.gicp_cloud_s, 1e3 * pt.matching_s,
                 1e3 * pt.ground_search_s, 1e3 * pt.ransac_s, 1e3 * pt.gicp_s, 1e3 * pt.p2p_s);
}

// The whole register_initial on one frame, its pose errors against the truth into `totals`.
void diagnose_register_initial(const std::string& dir, const bench::DiagnoseFrame& frame,
                               const core::InitialRegistrationParams& params, int threads,
                               bool show_tried, Totals* totals) {
    const std::size_t n = frame.clouds.size();
    const core::Stopwatch run_time;
    const core::InitialRegistrationResult result =
        core::register_initial(frame.clouds, params, threads);
    totals->register_initial_s += run_time.seconds();
    int registered = 0, wrong = 0;
    std::string line;
    for (std::size_t i = 0; i < n; ++i) {
        const auto& s = result.sensors[i];
        if (!s.registered) {
            line += " " + frame.names[i] + ":FAIL(" + core::to_string(s.status) + ")";
            continue;
        }
        ++registered;
        const double et = core::translation_error_m(s.T_root_sensor, frame.truth(0, i));
        const double er = core::rotation_error_deg(s.T_root_sensor, frame.truth(0, i));
        totals->worst_t = std::max(totals->worst_t, et);
        totals->worst_r = std::max(totals->worst_r, er);
        if (et > 0.03 || er > 0.1) ++wrong;
        char buf[128];
        std::snprintf(buf, sizeof buf, " %s:%.3fm/%.3fdeg", frame.names[i].c_str(), et, er);
        line += buf;
    }
    report_pairs(result, frame, show_tried);
    std::fprintf(stderr,
                 "%s: registered %d/%zu wrong %d time %.2f s (features %.2f pairs %.2f)%s\n",
                 dir.c_str(), registered, n, wrong, result.timings.total_s,
                 result.timings.features_s, result.timings.pairs_s, line.c_str());
    report_stage_sums(result);
    totals->sensors += static_cast<int>(n);
    totals->registered += registered;
    totals->wrong += wrong;
}

void print_totals(const Totals& t, std::size_t num_dirs) {
    std::printf("diagnose_sensors %d sensors\n", t.sensors);
    std::printf("diagnose_registered %d sensors\n", t.registered);
    std::printf("diagnose_wrong %d sensors\n", t.wrong);
    std::printf("diagnose_max_translation_error_cm %.2f cm\n", 100.0 * t.worst_t);
    std::printf("diagnose_max_rotation_error_deg %.4f deg\n", t.worst_r);
    std::printf("diagnose_mean_register_initial_s %.3f s\n",
                num_dirs == 0 ? 0.0 : t.register_initial_s / num_dirs);
}

}  // namespace

int main(int argc, char** argv) {
    std::vector<std::string> dirs;
    Options opts;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto eq = a.find('=');
        if (eq == std::string::npos) {
            dirs.push_back(a);
        } else {
            opts[a.substr(0, eq)] = a.substr(eq + 1);
        }
    }
    const core::InitialRegistrationParams params = registration_params(opts);
    const bench::StageOptions stages = stage_options(opts);
    const int threads = static_cast<int>(option(opts, "threads", 2));
    const bool quiet = option(opts, "quiet", 0) != 0;
    Totals totals;
    for (const std::string& dir : dirs) {
        const bench::DiagnoseFrame frame =
            bench::load_diagnose_frame(dir, option(opts, "truth_shift_s", 0.0));
        if (!quiet) {
            const std::vector<core::SensorFeatures> features =
                bench::diagnose_features(dir, frame, params, threads);
            for (std::size_t i = 1; i < features.size(); ++i) {
                for (std::size_t j = 0; j < i; ++j) {
                    bench::diagnose_pair(features[i], features[j], i, j, frame.truth(j, i),
                                         params.pair, stages);
                }
            }
        }
        if (stages.match_only) continue;
        diagnose_register_initial(dir, frame, params, threads, option(opts, "tried", 0) != 0,
                                  &totals);
    }
    print_totals(totals, dirs.size());
    return 0;
}
