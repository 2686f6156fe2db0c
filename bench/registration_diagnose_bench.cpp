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
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "core/common/kdtree.hpp"
#include "core/common/se3.hpp"
#include "core/initial/ground_aligned_search.hpp"
#include "core/initial/initial_registration.hpp"
#include "drivers/capture/station_capture.hpp"
#include "drivers/io/cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"
#include "drivers/io/rig_reference.hpp"
#include "drivers/station/station_config.hpp"

using namespace lidarfuse;

namespace {

struct Frame {
    std::vector<core::PointCloud> clouds;           // root first, like calibrate
    std::vector<Eigen::Isometry3d> T_world_sensor;  // truth at each scan's time
    std::vector<std::string> names;
};

// The first complete scan of every enabled sensor, and the truth nearest to its time.
Frame load_frame(const std::string& dir, double truth_shift_s) {
    const auto config = station::load_station_config(dir + "/station.yaml");
    capture::StationCapture capture(config, dir + "/capture.pcap");
    const std::size_t root = config.root_index();
    std::vector<std::size_t> order{root};
    for (std::size_t s = 0; s < config.sensors.size(); ++s) {
        if (s != root && config.sensors[s].enabled) order.push_back(s);
    }
    std::vector<core::PointCloud> clouds(config.sensors.size());
    std::vector<std::int64_t> t_ns(config.sensors.size(), -1);
    std::size_t have = 0;
    capture.run([&](const capture::CaptureScan& scan) {
        if (!scan.scan->complete() || t_ns[scan.sensor] >= 0) return true;
        clouds[scan.sensor] = scan.cloud->cloud;
        t_ns[scan.sensor] = scan.t_ns;
        return ++have < order.size();
    });
    const auto truth = io::read_pose_csv(dir + "/ground_truth.csv");
    Frame frame;
    for (std::size_t s : order) {
        frame.clouds.push_back(std::move(clouds[s]));
        frame.names.push_back(config.sensors[s].name);
        // Truth at t_ns + truth_shift_s, interpolated between the records around it.
        const std::int64_t want = t_ns[s] + static_cast<std::int64_t>(truth_shift_s * 1e9);
        const io::PoseRecord* before = nullptr;
        const io::PoseRecord* after = nullptr;
        for (const auto& r : truth) {
            if (r.sensor != config.sensors[s].name) continue;
            if (r.t_ns <= want && (before == nullptr || r.t_ns > before->t_ns)) before = &r;
            if (r.t_ns >= want && (after == nullptr || r.t_ns < after->t_ns)) after = &r;
        }
        if (before == nullptr) before = after;
        if (after == nullptr) after = before;
        if (before == nullptr)
            throw std::runtime_error(dir + ": no truth for " + config.sensors[s].name);
        const double a = after->t_ns == before->t_ns ? 0.0
                                                     : static_cast<double>(want - before->t_ns) /
                                                           (after->t_ns - before->t_ns);
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.translation() = (1 - a) * before->pose.translation() + a * after->pose.translation();
        T.linear() = Eigen::Quaterniond(before->pose.linear())
                         .slerp(a, Eigen::Quaterniond(after->pose.linear()))
                         .toRotationMatrix();
        frame.T_world_sensor.push_back(T);
    }
    return frame;
}

// register_pair's G-ICP runs, one per correspondence bound, each from the last result.
core::GicpResult coarse_to_fine(const core::PairRegistrationParams& p,
                                const core::GicpTarget& target, const core::PointCloud& source,
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

// A real rig folder: the root's cloud first, then every sensor it has a reference to.
Frame load_rig(const std::string& dir) {
    std::string root;
    std::map<std::string, Eigen::Isometry3d> references;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        const auto sep = name.find('_', 2);
        if (name.rfind("T_", 0) != 0 || entry.path().extension() != ".txt" ||
            sep == std::string::npos)
            continue;
        const std::string a = name.substr(2, sep - 2);
        if (!root.empty() && a != root)
            throw std::runtime_error(dir + ": references from two roots, " + root + " and " + a);
        root = a;
        references[entry.path().stem().string().substr(sep + 1)] =
            io::read_rig_reference(entry.path());
    }
    if (root.empty())
        throw std::runtime_error(dir + ": no station.yaml and no T_ROOT_NAME.txt references");
    auto cloud_of = [&](const std::string& name) {
        for (const char* ext : {".pcd", ".ply"}) {
            if (std::filesystem::exists(dir + "/" + name + ext))
                return io::read_cloud_file(dir + "/" + name + ext).cloud;
        }
        throw std::runtime_error(dir + ": no " + name + ".pcd or " + name + ".ply");
    };
    Frame frame;
    frame.clouds.push_back(cloud_of(root));
    frame.names.push_back(root);
    frame.T_world_sensor.push_back(Eigen::Isometry3d::Identity());
    for (const auto& [name, T_root_name] : references) {
        frame.clouds.push_back(cloud_of(name));
        frame.names.push_back(name);
        frame.T_world_sensor.push_back(T_root_name);
    }
    return frame;
}

double option(const std::map<std::string, std::string>& opts, const std::string& key,
              double fallback) {
    const auto it = opts.find(key);
    return it == opts.end() ? fallback : std::atof(it->second.c_str());
}

// "0.3,0.2" -> {0.3, 0.2}; "0" -> {} (values <= 0 are left out).
std::vector<double> list_option(const std::map<std::string, std::string>& opts,
                                const std::string& key, const std::vector<double>& fallback) {
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

}  // namespace

int main(int argc, char** argv) {
    std::vector<std::string> dirs;
    std::map<std::string, std::string> opts;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto eq = a.find('=');
        if (eq == std::string::npos) {
            dirs.push_back(a);
        } else {
            opts[a.substr(0, eq)] = a.substr(eq + 1);
        }
    }
    core::InitialRegistrationParams params = core::default_initial_registration_params();
    auto& f = params.features;
    f.fpfh.radius_m = option(opts, "fpfh_radius", f.fpfh.radius_m);
    f.sift.min_scale_m = option(opts, "sift_scale", f.sift.min_scale_m);
    f.sift.min_contrast = option(opts, "sift_contrast", f.sift.min_contrast);
    f.sift.octaves = static_cast<int>(option(opts, "sift_octaves", f.sift.octaves));
    f.octree.max_voxel_size_m = option(opts, "octree_max", f.octree.max_voxel_size_m);
    f.octree.min_voxel_size_m = option(opts, "octree_min", f.octree.min_voxel_size_m);
    f.normals.k_neighbors = static_cast<int>(option(opts, "normals_k", f.normals.k_neighbors));
    auto& p = params.pair;
    p.matching.ratio = option(opts, "ratio", p.matching.ratio);
    p.matching.mutual = option(opts, "mutual", p.matching.mutual ? 1 : 0) != 0;
    p.matching.candidates_per_source =
        static_cast<int>(option(opts, "candidates_per_source", p.matching.candidates_per_source));
    p.ransac.max_iterations =
        static_cast<int>(option(opts, "ransac_iterations", p.ransac.max_iterations));
    p.ransac.inlier_threshold_m = option(opts, "ransac_threshold", p.ransac.inlier_threshold_m);
    params.num_threads = static_cast<int>(option(opts, "threads", 2));
    params.consensus.min_bridge_information_per_inlier =
        option(opts, "min_bridge_info", params.consensus.min_bridge_information_per_inlier);
    p.max_free_space_violation_share =
        option(opts, "max_free_space", p.max_free_space_violation_share);
    f.gicp_voxel_size_m = option(opts, "gicp_voxel", f.gicp_voxel_size_m);
    p.gicp_max_correspondence_m.back() =
        option(opts, "gicp_fine", p.gicp_max_correspondence_m.back());
    f.polish_voxel_size_m = option(opts, "polish_voxel", f.polish_voxel_size_m);
    params.polish.max_correspondence_m =
        list_option(opts, "polish", params.polish.max_correspondence_m);
    const bool quiet = option(opts, "quiet", 0) != 0;
    const bool show_tried = option(opts, "tried", 0) != 0;
    const bool match_only = option(opts, "match_only", 0) != 0;
    const double threshold_m = p.ransac.inlier_threshold_m;

    int total_sensors = 0, total_registered = 0, total_wrong = 0;
    double worst_t = 0.0, worst_r = 0.0, total_s = 0.0;
    for (const std::string& dir : dirs) {
        const Frame frame = std::filesystem::exists(dir + "/station.yaml")
                                ? load_frame(dir, option(opts, "truth_shift_s", 0.0))
                                : load_rig(dir);
        const std::size_t n = frame.clouds.size();
        auto truth = [&](std::size_t target, std::size_t source) {
            return Eigen::Isometry3d(frame.T_world_sensor[target].inverse() *
                                     frame.T_world_sensor[source]);
        };
        if (!quiet) {
            core::SensorFeatureParams fp = params.features;
            fp.num_threads = params.num_threads;
            std::vector<core::SensorFeatures> features;
            for (std::size_t i = 0; i < n; ++i) {
                features.push_back(
                    core::compute_sensor_features(frame.clouds[i], fp, params.min_keypoints));
                const auto& g = features[i].ground;
                const Eigen::Vector3d up_true =
                    frame.T_world_sensor[i].linear().transpose() * Eigen::Vector3d::UnitZ();
                std::fprintf(
                    stderr,
                    "%s %s: points %zu pre %zu octree %zu keypoints %zu status %s ground %d h %.3f "
                    "(true %.3f) up_err %.3f deg inl %zu\n",
                    dir.c_str(), frame.names[i].c_str(), features[i].num_input_points,
                    features[i].num_preprocessed_points, features[i].octree.cloud.size(),
                    features[i].keypoints.size(), core::to_string(features[i].status),
                    g.found ? 1 : 0, g.sensor_height_m, frame.T_world_sensor[i].translation().z(),
                    std::acos(std::min(1.0, g.up.dot(up_true))) * 180 / M_PI, g.num_inliers);
            }
            for (std::size_t i = 1; i < n; ++i) {
                for (std::size_t j = 0; j < i; ++j) {
                    const auto& src = features[i];
                    const auto& tgt = features[j];
                    if (src.keypoint_points.empty() || tgt.keypoint_points.empty()) continue;
                    const Eigen::Isometry3d T = truth(j, i);
                    // Repeatability: source keypoints that land near a target keypoint, among
                    // those that land near the target's octree cloud (in the overlap).
                    const core::KdTree kp_tree(tgt.keypoint_points);
                    const core::KdTree cloud_tree(tgt.octree.cloud.points);
                    int in_overlap = 0, repeated = 0;
                    for (const auto& q : src.keypoint_points) {
                        std::uint32_t idx = 0;
                        double d2 = 0.0;
                        const Eigen::Vector3d m = T * q;
                        if (!cloud_tree.nearest(m, &idx, &d2) || d2 > 0.25) continue;
                        ++in_overlap;
                        if (kp_tree.nearest(m, &idx, &d2) && d2 <= threshold_m * threshold_m)
                            ++repeated;
                    }
                    const core::Correspondences matches =
                        core::match_features(src.descriptors, tgt.descriptors, p.matching);
                    int true_matches = 0;
                    for (const auto& c : matches) {
                        if ((T * src.keypoint_points[c.source] - tgt.keypoint_points[c.target])
                                .norm() <= threshold_m) {
                            ++true_matches;
                        }
                    }
                    // Descriptor quality: rank of the true partner among all target descriptors (0
                    // = best).
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
                    if (!ranks.empty()) {
                        std::fprintf(
                            stderr, "  ranks %zu->%zu: n %zu p25 %.3f p50 %.3f p75 %.3f p90 %.3f\n",
                            i, j, ranks.size(), ranks[ranks.size() / 4], ranks[ranks.size() / 2],
                            ranks[ranks.size() * 3 / 4], ranks[ranks.size() * 9 / 10]);
                    }
                    std::fprintf(
                        stderr,
                        "  pair %zu->%zu: kp %zu/%zu in_overlap %d repeatable %d matches %zu "
                        "true %d (%.3f)\n",
                        i, j, src.keypoints.size(), tgt.keypoints.size(), in_overlap, repeated,
                        matches.size(), true_matches,
                        matches.empty() ? 0.0 : static_cast<double>(true_matches) / matches.size());
                    {
                        // The checks at the truth: what the free-space test and G-ICP say of
                        // the right transform (a right pair refused by a check shows here).
                        const auto a =
                            core::free_space_violations(src.gicp.cloud().points, tgt.free_space, T);
                        const auto b = core::free_space_violations(tgt.gicp.cloud().points,
                                                                   src.free_space, T.inverse());
                        std::fprintf(stderr,
                                     "    truth free space: source->target %zu/%zu %.3f  "
                                     "target->source %zu/%zu %.3f\n",
                                     a.num_violations, a.num_tested, a.violation_share,
                                     b.num_violations, b.num_tested, b.violation_share);
                        const core::GicpResult gr =
                            coarse_to_fine(p, tgt.gicp, src.gicp.cloud(), T);
                        const Eigen::Isometry3d Tc = gr.T_target_source;
                        core::P2pErrorParams pp;
                        pp.cutoff_radius_m = p.p2p_cutoff_m;
                        const auto pe =
                            core::p2p_error(src.gicp.cloud().points, tgt.gicp.tree(), Tc, pp);
                        std::fprintf(
                            stderr,
                            "    G-ICP from the truth: moves %.3f m %.3f deg, converged %d in %d, "
                            "inliers %.3f, "
                            "p2p %.3f m, overlap %.3f, info/inlier %.2f\n",
                            core::translation_error_m(Tc, T), core::rotation_error_deg(Tc, T),
                            gr.converged ? 1 : 0, gr.iterations, gr.inlier_ratio, pe.error_m,
                            pe.overlap_share,
                            core::information_per_inlier(gr.H_eigenvalues(0), gr.num_inliers));
                    }
                    {
                        core::GroundAlignedKeypoints ks{&src.keypoint_points, &src.keypoint_normals,
                                                        &src.descriptors,
                                                        src.ground.T_ground_sensor};
                        core::GroundAlignedKeypoints kt{&tgt.keypoint_points, &tgt.keypoint_normals,
                                                        &tgt.descriptors,
                                                        tgt.ground.T_ground_sensor};
                        core::GroundAlignedSearchParams gp;
                        gp.descriptor_rank_share = option(opts, "rank_share", 1.0);
                        gp.max_height_difference_m = option(opts, "height_diff", 1.0);
                        gp.min_height_m = option(opts, "min_height", gp.min_height_m);
                        gp.max_peaks = static_cast<int>(option(opts, "peaks", gp.max_peaks));
                        const auto t0 = std::chrono::steady_clock::now();
                        const auto cands = core::ground_aligned_search(ks, kt, gp);
                        const double dt =
                            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0)
                                .count();
                        if (option(opts, "refine", 0) != 0) {
                            for (const auto& c : cands) {
                                const auto coarse = core::free_space_violations_both(
                                    src.gicp.cloud().points, src.free_space,
                                    tgt.gicp.cloud().points, tgt.free_space, c.T_target_source);
                                if (coarse.violation_share >
                                    p.max_ground_coarse_free_space_violation_share)
                                    continue;
                                const core::GicpResult gr = coarse_to_fine(
                                    p, tgt.gicp, src.gicp.cloud(), c.T_target_source);
                                const Eigen::Isometry3d Tc = gr.T_target_source;
                                const auto fs = core::free_space_violations_both(
                                    src.gicp.cloud().points, src.free_space,
                                    tgt.gicp.cloud().points, tgt.free_space, Tc);
                                core::P2pErrorParams pp;
                                pp.cutoff_radius_m = p.p2p_cutoff_m;
                                const auto pe = core::p2p_error(src.gicp.cloud().points,
                                                                tgt.gicp.tree(), Tc, pp);
                                std::fprintf(stderr,
                                             "    refined %zu->%zu: start %.2fm err %.3fm %.3fdeg "
                                             "fs %.4f coarse %.3f p2p %.3f N %zu inl %.2f it %d\n",
                                             i, j, core::translation_error_m(c.T_target_source, T),
                                             core::translation_error_m(Tc, T),
                                             core::rotation_error_deg(Tc, T), fs.violation_share,
                                             coarse.violation_share, pe.error_m,
                                             pe.num_within_cutoff, gr.inlier_ratio, gr.iterations);
                            }
                        }
                        std::fprintf(stderr, "    ground search %.1f ms:", dt * 1e3);
                        for (const auto& c : cands) {
                            const auto fs = core::free_space_violations_both(
                                src.gicp.cloud().points, src.free_space, tgt.gicp.cloud().points,
                                tgt.free_space, c.T_target_source);
                            std::fprintf(stderr, " [v%d i%zu fs%.3f %.2fm %.2fdeg]", c.votes,
                                         c.inliers.size(), fs.violation_share,
                                         core::translation_error_m(c.T_target_source, T),
                                         core::rotation_error_deg(c.T_target_source, T));
                        }
                        std::fprintf(stderr, "\n");
                    }
                    core::Correspondences remaining = matches;
                    for (int round = 0;
                         !match_only && round < p.max_candidates && remaining.size() >= 3;
                         ++round) {
                        core::RansacParams rp = p.ransac;
                        rp.seed = p.ransac.seed + static_cast<std::uint32_t>(round);
                        const auto r = core::ransac_registration(
                            src.keypoint_points, tgt.keypoint_points, remaining, rp);
                        if (!r.success) break;
                        std::fprintf(
                            stderr, "    round %d: inliers %zu iterations %d err %.2f m %.2f deg\n",
                            round, r.inliers.size(), r.iterations,
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
            }
        }
        if (match_only) continue;
        const auto start = std::chrono::steady_clock::now();
        const core::InitialRegistrationResult result = core::register_initial(frame.clouds, params);
        total_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        int registered = 0, wrong = 0;
        std::string line;
        for (std::size_t i = 0; i < n; ++i) {
            const auto& s = result.sensors[i];
            if (!s.registered) {
                line += " " + frame.names[i] + ":FAIL(" + core::to_string(s.status) + ")";
                continue;
            }
            ++registered;
            const double et = core::translation_error_m(s.T_root_sensor, truth(0, i));
            const double er = core::rotation_error_deg(s.T_root_sensor, truth(0, i));
            worst_t = std::max(worst_t, et);
            worst_r = std::max(worst_r, er);
            if (et > 0.03 || er > 0.1) ++wrong;
            char buf[128];
            std::snprintf(buf, sizeof buf, " %s:%.3fm/%.3fdeg", frame.names[i].c_str(), et, er);
            line += buf;
        }
        for (const auto& pair : result.pairs) {
            const Eigen::Isometry3d T = truth(pair.target, pair.source);
            std::fprintf(stderr,
                         "  result %d->%d: %s ransac_inliers %zu cand %d alt %zu chosen %d err "
                         "%.3f m %.3f deg\n",
                         pair.source, pair.target, core::to_string(pair.status),
                         pair.chosen.ransac_inliers, pair.candidates, pair.alternatives.size(),
                         pair.chosen.candidate,
                         core::translation_error_m(pair.chosen.T_target_source, T),
                         core::rotation_error_deg(pair.chosen.T_target_source, T));
            // Every candidate that reached G-ICP: which check dropped it, against the truth.
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
        std::fprintf(stderr,
                     "%s: registered %d/%zu wrong %d time %.2f s (features %.2f pairs %.2f)%s\n",
                     dir.c_str(), registered, n, wrong, result.timings.total_s,
                     result.timings.features_s, result.timings.pairs_s, line.c_str());
        {
            const core::StageTimeSums sums = core::sum_stage_timings(result);
            const core::SensorFeatureTimings& ft = sums.features;
            const core::PairTimings& pt = sums.pairs;
            std::fprintf(stderr,
                         "  stage sums ms: preprocess %.0f normals %.0f octree %.0f sift %.0f fpfh "
                         "%.0f ground %.0f "
                         "gicp_cloud %.0f | matching %.0f ground_search %.0f ransac %.0f gicp %.0f "
                         "p2p %.0f\n",
                         1e3 * ft.preprocess_s, 1e3 * ft.normals_s, 1e3 * ft.octree_s,
                         1e3 * ft.keypoints_s, 1e3 * ft.fpfh_s, 1e3 * ft.ground_s,
                         1e3 * ft.gicp_cloud_s, 1e3 * pt.matching_s, 1e3 * pt.ground_search_s,
                         1e3 * pt.ransac_s, 1e3 * pt.gicp_s, 1e3 * pt.p2p_s);
        }
        total_sensors += static_cast<int>(n);
        total_registered += registered;
        total_wrong += wrong;
    }
    std::printf("diagnose_sensors %d sensors\n", total_sensors);
    std::printf("diagnose_registered %d sensors\n", total_registered);
    std::printf("diagnose_wrong %d sensors\n", total_wrong);
    std::printf("diagnose_max_translation_error_cm %.2f cm\n", 100.0 * worst_t);
    std::printf("diagnose_max_rotation_error_deg %.4f deg\n", worst_r);
    std::printf("diagnose_mean_register_initial_s %.3f s\n",
                dirs.empty() ? 0.0 : total_s / dirs.size());
    return 0;
}
