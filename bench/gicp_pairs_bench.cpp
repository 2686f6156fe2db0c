// G-ICP on pairs of whole scans, written out so that another implementation can register the
// very same points from the very same start (issue 17: side by side with small_gicp), and
// timed stage by stage as the continuous registration runs them:
//   voxel grid   VoxelGrid::downsample, centroids in space order (sensor_track.cpp)
//   tree         our k-d tree over the centroids (KdTree, leaf size 10)
//   covariances  the k nearest of every centroid and its plane covariance (GicpCloud, which
//                builds the tree too: this stage is GicpCloud's time less the tree's)
//   alignment    GicpRegistration::align (Levenberg-Marquardt, the exact searches of gicp.hpp)
// for both clouds of a pair (each is a source of some edges and a target of others).
//
//   gicp_pairs_bench write OUT [CAPTURE_DIR [FRAMES]] [REAL_DIR]
//     Makes the pairs and writes OUT/pairs.txt and the clouds (the format:
//     gicp_pair_files.hpp). Without CAPTURE_DIR it simulates the curve, seed 1, into
//     OUT/capture; FRAMES scans per sensor (3); REAL_DIR defaults to $LIDARFUSE_DATA_DIR/real.
//   gicp_pairs_bench run OUT [THREADS [REPETITIONS]]
//     Registers every pair of OUT/pairs.txt, each stage's wall time the fastest of
//     REPETITIONS (5); prints `name value unit` lines (per setting: medians over its pairs)
//     and writes the result file OUT/ours_t<THREADS>.txt.
//   gicp_pairs_bench compare OUT A B
//     Two result files in OUT: the largest difference between their poses (the same pair
//     names), and per pair kind and setting the medians of A's and B's stages and totals,
//     their ratio, and each file's median error to the pairs' reference.
//
// Pairs: sim_temporal (each sensor, scan k+1 onto scan k, started 2 cm / 0.1 deg off the
// true motion), sim_spatial (each sensor onto the root at the same frame, started 10 cm /
// 0.5 deg off the truth), real_edgar (frontleft onto frontright), real_opencalib (left and
// right onto top), the real ones started 10 cm / 0.5 deg off the reference. Settings, the
// continuous registration's defaults at two voxel sizes: 1 m (k = 6, bound 1 m) and 0.25 m
// (k = 12, bound 0.25 m), 30 iterations, eps 1e-4, LM from lambda 1e-4.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/gicp_pair_files.hpp"
#include "core/common/kdtree.hpp"
#include "core/common/se3.hpp"
#include "core/common/stopwatch.hpp"
#include "core/pipeline/fusion_types.hpp"
#include "core/preprocess/voxel_grid.hpp"
#include "core/registration/gicp.hpp"
#include "core/registration/gicp_cloud.hpp"
#include "drivers/capture/station_capture.hpp"
#include "drivers/io/cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"
#include "drivers/io/rig_reference.hpp"
#include "drivers/station/station_config.hpp"

namespace {

namespace fs = std::filesystem;
using lidarfuse::bench::GicpPair;
using lidarfuse::core::PointCloud;
using Points = std::vector<Eigen::Vector3d>;

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr int kMaxIterations = 30;
constexpr double kEps = 1e-4;

void print(const std::string& name, double value, const char* unit) {
    std::printf("%s %.6g %s\n", name.c_str(), value, unit);
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

// ---- write ------------------------------------------------------------------------------

struct PairSpec {
    std::string name, target, source;  // cloud names (files without .f64)
    Eigen::Isometry3d T_init, T_ref;
};

Eigen::Isometry3d nudged(const Eigen::Isometry3d& T, double deg, double m) {
    lidarfuse::core::Vector6d xi;  // rotation (rad) then translation (m)
    xi << deg * kDeg, 0.5 * deg * kDeg, 0.0, m, 0.5 * m, 0.0;
    return T * lidarfuse::core::se3_exp(xi);
}

// scans[sensor][frame], decoded by the production ingest.
std::vector<std::vector<Points>> decode_capture(const fs::path& dir, std::size_t frames,
                                                std::vector<std::string>* names) {
    const auto station = lidarfuse::station::load_station_config(dir / "station.yaml");
    lidarfuse::capture::StationCapture capture(station, dir / "capture.pcap");
    std::vector<std::vector<Points>> scans(station.sensors.size());
    capture.run([&](const lidarfuse::capture::CaptureScan& s) {
        if (scans[s.sensor].size() < frames) scans[s.sensor].push_back(s.cloud->cloud.points);
        return true;
    });
    for (const auto& sensor : station.sensors) names->push_back(sensor.name);
    return scans;
}

void add_sim_pairs(const fs::path& capture_dir, std::size_t frames, const fs::path& out,
                   std::vector<PairSpec>* pairs) {
    std::vector<std::string> names;
    const auto scans = decode_capture(capture_dir, frames, &names);
    std::map<std::string, std::vector<Eigen::Isometry3d>> truth;  // per sensor, frame order
    for (const auto& r : lidarfuse::io::read_pose_csv(capture_dir / "ground_truth.csv")) {
        truth[r.sensor].push_back(r.pose);
    }
    const auto cloud = [&](std::size_t s, std::size_t k) {
        const std::string name = "sim_" + names[s] + "_" + std::to_string(k);
        lidarfuse::bench::write_pair_points(out / (name + ".f64"), scans[s][k]);
        return name;
    };
    for (std::size_t s = 0; s < scans.size(); ++s) {
        const auto& gt = truth.at(names[s]);
        for (std::size_t k = 0; k + 1 < scans[s].size() && k + 1 < gt.size(); ++k) {
            const Eigen::Isometry3d motion = gt[k].inverse() * gt[k + 1];
            pairs->push_back({"sim_temporal_" + names[s] + "_" + std::to_string(k), cloud(s, k),
                              cloud(s, k + 1), nudged(motion, 0.1, 0.02), motion});
            if (s == 0) continue;
            const Eigen::Isometry3d T = truth.at(names[0])[k].inverse() * gt[k];
            pairs->push_back({"sim_spatial_" + names[s] + "_" + std::to_string(k), cloud(0, k),
                              cloud(s, k), nudged(T, 0.5, 0.1), T});
        }
    }
}

void add_real_pair(const fs::path& rig, const std::string& target, const std::string& source,
                   const fs::path& out, std::vector<PairSpec>* pairs) {
    const std::string prefix = "real_" + rig.filename().string() + "_";
    for (const std::string& name : {target, source}) {
        lidarfuse::bench::write_pair_points(
            out / (prefix + name + ".f64"),
            lidarfuse::io::read_pcd(rig / (name + ".pcd")).cloud.points);
    }
    const Eigen::Isometry3d T_ref =
        lidarfuse::io::read_rig_reference(rig / ("T_" + target + "_" + source + ".txt"));
    pairs->push_back({prefix + source + "_onto_" + target, prefix + target, prefix + source,
                      nudged(T_ref, 0.5, 0.1), T_ref});
}

void write_pairs_file(const fs::path& out, const std::vector<PairSpec>& pairs) {
    std::ofstream file(out / "pairs.txt");
    file.precision(17);
    for (const double voxel_m : {1.0, 0.25}) {
        const lidarfuse::core::FusionParams params;
        for (const PairSpec& spec : pairs) {
            lidarfuse::bench::GicpPair p;
            p.name = spec.name;
            p.voxel_m = voxel_m;
            p.k = lidarfuse::core::covariance_neighbors_for(params, voxel_m);
            p.bound_m = params.correspondence_factor * voxel_m;
            p.max_iterations = kMaxIterations;
            p.eps = kEps;
            p.target_file = spec.target + ".f64";
            p.source_file = spec.source + ".f64";
            p.T_init = spec.T_init;
            p.T_ref = spec.T_ref;
            lidarfuse::bench::write_gicp_pair(file, p);
        }
    }
    if (!file) throw std::runtime_error((out / "pairs.txt").string() + ": cannot write");
}

fs::path simulated_capture(const fs::path& out) {
    const fs::path dir = out / "capture";
    const std::string cmd = std::string("\"") + LIDARFUSE_TOOL_PATH +
                            "\" sim --scenario curve --seed 1 --seconds 0.2 --quiet --out \"" +
                            dir.string() + "\" > /dev/null";
    if (std::system(cmd.c_str()) != 0) throw std::runtime_error(cmd + " failed");
    return dir;
}

int write_command(int argc, char** argv) {
    const fs::path out = argv[2];
    fs::create_directories(out);
    const fs::path capture = argc > 3 ? fs::path(argv[3]) : simulated_capture(out);
    const std::size_t frames = argc > 4 ? static_cast<std::size_t>(std::atoi(argv[4])) : 3;
    const char* data = std::getenv("LIDARFUSE_DATA_DIR");
    const fs::path real =
        argc > 5 ? fs::path(argv[5]) : fs::path(data ? data : LIDARFUSE_DEFAULT_DATA_DIR) / "real";
    std::vector<PairSpec> pairs;
    add_sim_pairs(capture, frames, out, &pairs);
    if (fs::exists(real / "edgar_ouster_pair")) {
        add_real_pair(real / "edgar_ouster_pair", "frontright", "frontleft", out, &pairs);
    }
    if (fs::exists(real / "opencalib_road_rig")) {
        add_real_pair(real / "opencalib_road_rig", "top", "left", out, &pairs);
        add_real_pair(real / "opencalib_road_rig", "top", "right", out, &pairs);
    }
    write_pairs_file(out, pairs);
    print("gicp_pairs_written", static_cast<double>(pairs.size()), "pairs_per_setting");
    return 0;
}

// ---- run --------------------------------------------------------------------------------

struct StageTimes {
    double voxel = 1e300, tree = 1e300, covariances = 1e300, alignment = 1e300;
    double total() const { return voxel + tree + covariances + alignment; }
    void keep_fastest(const StageTimes& o) {
        voxel = std::min(voxel, o.voxel);
        tree = std::min(tree, o.tree);
        covariances = std::min(covariances, o.covariances);
        alignment = std::min(alignment, o.alignment);
    }
};

struct Registered {
    StageTimes times;
    lidarfuse::core::GicpResult result;
};

// A sensor's grid lives as long as its track and keeps its buffers from frame to frame
// (voxel_grid.hpp): each side of a pair keeps one over the repetitions, as a track does
// over its frames.
struct PairGrids {
    lidarfuse::core::VoxelGrid target, source;
};

PointCloud downsample(lidarfuse::core::VoxelGrid* grid, const Points& points, double voxel_m) {
    lidarfuse::core::VoxelGridParams params;
    params.voxel_size_m = voxel_m;
    params.spatial_order = true;
    PointCloud cloud;
    grid->downsample(points, params, &cloud);
    return cloud;
}

// One pass of the four stages over both clouds of the pair.
Registered register_once(const GicpPair& p, const Points& target, const Points& source, int threads,
                         PairGrids* grids) {
    Registered r;
    lidarfuse::core::Stopwatch t;
    PointCloud target_cloud = downsample(&grids->target, target, p.voxel_m);
    PointCloud source_cloud = downsample(&grids->source, source, p.voxel_m);
    r.times.voxel = t.milliseconds();
    t.restart();
    {
        const lidarfuse::core::KdTree a(target_cloud.points, 10, threads),
            b(source_cloud.points, 10, threads);
    }
    r.times.tree = t.milliseconds();
    lidarfuse::core::NormalParams normals;
    normals.k_neighbors = p.k;
    normals.compute_normals = false;
    t.restart();
    const lidarfuse::core::GicpCloud gicp_target(std::move(target_cloud), normals, 10, threads);
    const lidarfuse::core::GicpCloud gicp_source(std::move(source_cloud), normals, 10, threads);
    r.times.covariances = std::max(0.0, t.milliseconds() - r.times.tree);
    lidarfuse::core::GicpParams params;
    params.max_correspondence_distance_m = p.bound_m;
    params.max_iterations = p.max_iterations;
    params.translation_eps_m = p.eps;
    params.rotation_eps_rad = p.eps;
    t.restart();
    lidarfuse::core::GicpRegistration registration(params, threads);
    r.result = registration.align(gicp_target, gicp_source, p.T_init);
    r.times.alignment = t.milliseconds();
    return r;
}

lidarfuse::bench::PairResult result_of(const Registered& r) {
    lidarfuse::bench::PairResult out;
    out.stage_ms[0] = r.times.voxel;
    out.stage_ms[1] = r.times.tree;
    out.stage_ms[2] = r.times.covariances;
    out.stage_ms[3] = r.times.alignment;
    out.total_ms = r.times.total();
    out.T = r.result.T_target_source;
    return out;
}

std::string setting_tag(const GicpPair& p) {
    char tag[32];
    std::snprintf(tag, sizeof(tag), "voxel%gm", p.voxel_m);
    return tag;
}

int run_command(int argc, char** argv) {
    const fs::path out = argv[2];
    const int threads = argc > 3 ? std::max(1, std::atoi(argv[3])) : 1;
    const int repetitions = argc > 4 ? std::max(1, std::atoi(argv[4])) : 5;
    std::ofstream results(out / ("ours_t" + std::to_string(threads) + ".txt"));
    results.precision(17);
    std::map<std::string, std::vector<double>> totals, stage_ms, trans_cm, rot_deg;
    for (const GicpPair& p : lidarfuse::bench::read_gicp_pairs(out)) {
        const Points target = lidarfuse::bench::read_pair_points(out / p.target_file);
        const Points source = lidarfuse::bench::read_pair_points(out / p.source_file);
        PairGrids grids;
        Registered best = register_once(p, target, source, threads, &grids);
        for (int r = 1; r < repetitions; ++r) {
            best.times.keep_fastest(register_once(p, target, source, threads, &grids).times);
        }
        lidarfuse::bench::write_pair_result(results, p, result_of(best));
        const std::string key = setting_tag(p) + "_" + lidarfuse::bench::pair_kind(p.name);
        totals[key].push_back(best.times.total());
        stage_ms[key + "_voxel_grid"].push_back(best.times.voxel);
        stage_ms[key + "_tree"].push_back(best.times.tree);
        stage_ms[key + "_covariances"].push_back(best.times.covariances);
        stage_ms[key + "_alignment"].push_back(best.times.alignment);
        trans_cm[key].push_back(
            100.0 * lidarfuse::core::translation_error_m(best.result.T_target_source, p.T_ref));
        rot_deg[key].push_back(
            lidarfuse::core::rotation_error_deg(best.result.T_target_source, p.T_ref));
    }
    const std::string prefix = "gicp_pairs_ours_t" + std::to_string(threads) + "_";
    for (const auto& [key, v] : totals) print(prefix + key + "_median_total", median(v), "ms");
    for (const auto& [key, v] : stage_ms) print(prefix + key + "_median", median(v), "ms");
    for (const auto& [key, v] : trans_cm)
        print(prefix + key + "_median_error_to_ref", median(v), "cm");
    for (const auto& [key, v] : rot_deg)
        print(prefix + key + "_median_error_to_ref", median(v), "deg");
    return 0;
}

// ---- compare ----------------------------------------------------------------------------

constexpr const char* kStageNames[5] = {"voxel_grid", "tree", "covariances", "alignment", "total"};

// name@voxel_m (as the result files name a pair) -> the pair's reference pose.
std::map<std::string, Eigen::Isometry3d> references(const fs::path& out) {
    std::map<std::string, Eigen::Isometry3d> refs;
    for (const GicpPair& p : lidarfuse::bench::read_gicp_pairs(out)) {
        refs[lidarfuse::bench::result_name(p)] = p.T_ref;
    }
    return refs;
}

// Per pair kind and setting ("sim_temporal@1"), one file's stage times and errors.
struct Figures {
    std::map<std::string, std::vector<double>> ms, error_cm, error_deg;
    void add(const std::string& key, const lidarfuse::bench::PairResult& r,
             const Eigen::Isometry3d& T_ref) {
        for (int stage = 0; stage < 5; ++stage) {
            ms[key + "_" + kStageNames[stage]].push_back(stage < 4 ? r.stage_ms[stage]
                                                                   : r.total_ms);
        }
        error_cm[key].push_back(100.0 * lidarfuse::core::translation_error_m(r.T, T_ref));
        error_deg[key].push_back(lidarfuse::core::rotation_error_deg(r.T, T_ref));
    }
};

void print_comparison(const Figures& a, const Figures& b) {
    for (const auto& [key, v] : a.ms) {
        print("gicp_pairs_a_" + key, median(v), "ms");
        print("gicp_pairs_b_" + key, median(b.ms.at(key)), "ms");
        print("gicp_pairs_ratio_" + key, median(v) / median(b.ms.at(key)), "x");
    }
    for (const auto& [key, v] : a.error_cm) {
        print("gicp_pairs_a_" + key + "_median_error_to_ref", median(v), "cm");
        print("gicp_pairs_b_" + key + "_median_error_to_ref", median(b.error_cm.at(key)), "cm");
        print("gicp_pairs_a_" + key + "_median_error_to_ref", median(a.error_deg.at(key)), "deg");
        print("gicp_pairs_b_" + key + "_median_error_to_ref", median(b.error_deg.at(key)), "deg");
    }
}

int compare_command(char** argv) {
    const fs::path out = argv[2];
    const auto a = lidarfuse::bench::read_pair_results(out / argv[3]);
    const auto b = lidarfuse::bench::read_pair_results(out / argv[4]);
    const auto refs = references(out);
    double max_trans_m = 0.0, max_rot_deg = 0.0;
    Figures fa, fb;
    for (const auto& [name, ra] : a) {
        const auto it = b.find(name);
        if (it == b.end()) throw std::runtime_error(std::string(argv[4]) + ": no " + name);
        const auto ref = refs.find(name);
        if (ref == refs.end()) throw std::runtime_error("pairs.txt: no " + name);
        max_trans_m =
            std::max(max_trans_m, lidarfuse::core::translation_error_m(ra.T, it->second.T));
        max_rot_deg =
            std::max(max_rot_deg, lidarfuse::core::rotation_error_deg(ra.T, it->second.T));
        const std::size_t at = name.find('@');
        const std::string key =
            lidarfuse::bench::pair_kind(name.substr(0, at)) + "@" + name.substr(at + 1);
        fa.add(key, ra, ref->second);
        fb.add(key, it->second, ref->second);
    }
    print("gicp_pairs_compared", static_cast<double>(a.size()), "pairs");
    print("gicp_pairs_max_pose_difference", max_trans_m * 1e3, "mm");
    print("gicp_pairs_max_pose_difference", max_rot_deg, "deg");
    print_comparison(fa, fb);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    const std::string command = argc > 2 ? argv[1] : "";
    try {
        if (command == "write") return write_command(argc, argv);
        if (command == "run") return run_command(argc, argv);
        if (command == "compare" && argc > 4) return compare_command(argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "gicp_pairs_bench: %s\n", e.what());
        return 1;
    }
    std::fprintf(stderr,
                 "usage: gicp_pairs_bench write OUT [CAPTURE_DIR [FRAMES]] [REAL_DIR]\n"
                 "       gicp_pairs_bench run OUT [THREADS [REPETITIONS]]\n"
                 "       gicp_pairs_bench compare OUT A B\n");
    return 2;
}
