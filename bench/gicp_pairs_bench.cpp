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
//     Makes the pairs and writes OUT/pairs.txt and the clouds (OUT/<cloud>.f64: the scan's
//     points, sensor frame, metres, x y z as little-endian float64, nothing else). One line
//     per pair and setting:
//       name voxel_m k bound_m max_iterations eps target.f64 source.f64 T_init(16) T_ref(16)
//     T_* are T_target_source, 4 x 4 row-major; T_ref is the truth (simulated pairs) or the
//     rig's published reference (real pairs); eps bounds both the rotation (rad) and the
//     translation (m) of the last update. Without CAPTURE_DIR it simulates the curve,
//     seed 1, into OUT/capture; REAL_DIR defaults to $LIDARFUSE_DATA_DIR/real.
//   gicp_pairs_bench run OUT [THREADS [REPETITIONS]]
//     Registers every pair of OUT/pairs.txt, each stage's wall time the fastest of
//     REPETITIONS; prints `name value unit` lines (per setting: medians over its pairs) and
//     writes OUT/ours_t<THREADS>.txt, one line per pair: name, the four stage times (ms),
//     the total, the pose T_target_source (16, row-major).
//   gicp_pairs_bench compare OUT A B
//     The largest difference between the poses of two such files (the same pair names), and
//     each file's median total per setting: prints `name value unit` lines.
//
// Pairs: sim_temporal (each sensor, scan k+1 onto scan k, started 2 cm / 0.1 deg off the
// true motion), sim_spatial (each sensor onto the root at the same frame, started 10 cm /
// 0.5 deg off the truth), real_edgar (frontleft onto frontright), real_opencalib (left and
// right onto top), the real ones started 10 cm / 0.5 deg off the reference. Settings, the
// continuous registration's defaults at two voxel sizes: 1 m (k = 6, bound 1 m) and 0.25 m
// (k = 12, bound 0.25 m), 30 iterations, eps 1e-4, LM from lambda 1e-4.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/common/kdtree.hpp"
#include "core/common/se3.hpp"
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

void write_points(const fs::path& file, const Points& points) {
    std::ofstream out(file, std::ios::binary);
    for (const Eigen::Vector3d& p : points) {
        out.write(reinterpret_cast<const char*>(p.data()), 3 * sizeof(double));
    }
    if (!out) throw std::runtime_error(file.string() + ": cannot write");
}

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
        write_points(out / (name + ".f64"), scans[s][k]);
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
        write_points(out / (prefix + name + ".f64"),
                     lidarfuse::io::read_pcd(rig / (name + ".pcd")).cloud.points);
    }
    const Eigen::Isometry3d T_ref =
        lidarfuse::io::read_rig_reference(rig / ("T_" + target + "_" + source + ".txt"));
    pairs->push_back({prefix + source + "_onto_" + target, prefix + target, prefix + source,
                      nudged(T_ref, 0.5, 0.1), T_ref});
}

void write_matrix(std::ostream& out, const Eigen::Isometry3d& T) {
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out << ' ' << T.matrix()(r, c);
}

void write_pairs_file(const fs::path& out, const std::vector<PairSpec>& pairs) {
    std::ofstream file(out / "pairs.txt");
    file.precision(17);
    for (const double voxel_m : {1.0, 0.25}) {
        lidarfuse::core::FusionParams params;
        const int k = lidarfuse::core::covariance_neighbors_for(params, voxel_m);
        const double bound_m = params.correspondence_factor * voxel_m;
        for (const PairSpec& p : pairs) {
            file << p.name << ' ' << voxel_m << ' ' << k << ' ' << bound_m << ' ' << kMaxIterations
                 << ' ' << kEps << ' ' << p.target << ".f64 " << p.source << ".f64";
            write_matrix(file, p.T_init);
            write_matrix(file, p.T_ref);
            file << '\n';
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

struct Pair {
    std::string name;
    double voxel_m = 1.0, bound_m = 1.0, eps = kEps;
    int k = 6, max_iterations = kMaxIterations;
    std::string target_file, source_file;
    Eigen::Isometry3d T_init = Eigen::Isometry3d::Identity(), T_ref = T_init;
};

Eigen::Isometry3d read_matrix(std::istream& in) {
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) in >> m(r, c);
    return Eigen::Isometry3d(m);
}

std::vector<Pair> read_pairs(const fs::path& out) {
    std::ifstream file(out / "pairs.txt");
    if (!file) throw std::runtime_error((out / "pairs.txt").string() + ": cannot read");
    std::vector<Pair> pairs;
    std::string line;
    while (std::getline(file, line)) {
        std::istringstream in(line);
        Pair p;
        in >> p.name >> p.voxel_m >> p.k >> p.bound_m >> p.max_iterations >> p.eps >>
            p.target_file >> p.source_file;
        p.T_init = read_matrix(in);
        p.T_ref = read_matrix(in);
        if (!in) throw std::runtime_error((out / "pairs.txt").string() + ": bad line: " + line);
        pairs.push_back(p);
    }
    return pairs;
}

Points read_points(const fs::path& file) {
    std::ifstream in(file, std::ios::binary | std::ios::ate);
    if (!in) throw std::runtime_error(file.string() + ": cannot read");
    Points points(static_cast<std::size_t>(in.tellg()) / (3 * sizeof(double)));
    in.seekg(0);
    in.read(reinterpret_cast<char*>(points.data()),
            static_cast<std::streamsize>(points.size() * 3 * sizeof(double)));
    return points;
}

double ms_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
}

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
Registered register_once(const Pair& p, const Points& target, const Points& source, int threads,
                         PairGrids* grids) {
    using clock = std::chrono::steady_clock;
    Registered r;
    auto t = clock::now();
    PointCloud target_cloud = downsample(&grids->target, target, p.voxel_m);
    PointCloud source_cloud = downsample(&grids->source, source, p.voxel_m);
    r.times.voxel = ms_since(t);
    t = clock::now();
    {
        const lidarfuse::core::KdTree a(target_cloud.points, 10, threads),
            b(source_cloud.points, 10, threads);
    }
    r.times.tree = ms_since(t);
    lidarfuse::core::NormalParams normals;
    normals.k_neighbors = p.k;
    normals.compute_normals = false;
    t = clock::now();
    const lidarfuse::core::GicpCloud gicp_target(std::move(target_cloud), normals, 10, threads);
    const lidarfuse::core::GicpCloud gicp_source(std::move(source_cloud), normals, 10, threads);
    r.times.covariances = std::max(0.0, ms_since(t) - r.times.tree);
    lidarfuse::core::GicpParams params;
    params.max_correspondence_distance_m = p.bound_m;
    params.max_iterations = p.max_iterations;
    params.translation_eps_m = p.eps;
    params.rotation_eps_rad = p.eps;
    t = clock::now();
    lidarfuse::core::GicpRegistration registration(params, threads);
    r.result = registration.align(gicp_target, gicp_source, p.T_init);
    r.times.alignment = ms_since(t);
    return r;
}

void write_result_line(std::ostream& out, const Pair& p, const Registered& r) {
    out << p.name << '@' << p.voxel_m << ' ' << r.times.voxel << ' ' << r.times.tree << ' '
        << r.times.covariances << ' ' << r.times.alignment << ' ' << r.times.total();
    write_matrix(out, r.result.T_target_source);
    out << '\n';
}

std::string setting_tag(const Pair& p) {
    char tag[32];
    std::snprintf(tag, sizeof(tag), "voxel%gm", p.voxel_m);
    return tag;
}

std::string kind_of(const std::string& name) {
    return name.rfind("sim_temporal", 0) == 0  ? "sim_temporal"
           : name.rfind("sim_spatial", 0) == 0 ? "sim_spatial"
                                               : name;
}

int run_command(int argc, char** argv) {
    const fs::path out = argv[2];
    const int threads = argc > 3 ? std::max(1, std::atoi(argv[3])) : 1;
    const int repetitions = argc > 4 ? std::max(1, std::atoi(argv[4])) : 5;
    std::ofstream results(out / ("ours_t" + std::to_string(threads) + ".txt"));
    results.precision(17);
    std::map<std::string, std::vector<double>> totals, stage_ms, trans_cm, rot_deg;
    for (const Pair& p : read_pairs(out)) {
        const Points target = read_points(out / p.target_file);
        const Points source = read_points(out / p.source_file);
        PairGrids grids;
        Registered best = register_once(p, target, source, threads, &grids);
        for (int r = 1; r < repetitions; ++r) {
            best.times.keep_fastest(register_once(p, target, source, threads, &grids).times);
        }
        write_result_line(results, p, best);
        const std::string key = setting_tag(p) + "_" + kind_of(p.name);
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

struct ResultLine {
    double stage_ms[4] = {0.0, 0.0, 0.0, 0.0};  // voxel grid, tree, covariances, alignment
    double total_ms = 0.0;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
};

std::map<std::string, ResultLine> read_results(const fs::path& file) {
    std::ifstream in(file);
    if (!in) throw std::runtime_error(file.string() + ": cannot read");
    std::map<std::string, ResultLine> lines;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream s(line);
        std::string name;
        ResultLine r;
        s >> name >> r.stage_ms[0] >> r.stage_ms[1] >> r.stage_ms[2] >> r.stage_ms[3] >> r.total_ms;
        r.T = read_matrix(s);
        if (!s) throw std::runtime_error(file.string() + ": bad line: " + line);
        lines[name] = r;
    }
    return lines;
}

constexpr const char* kStageNames[5] = {"voxel_grid", "tree", "covariances", "alignment", "total"};

int compare_command(char** argv) {
    const fs::path out = argv[2];
    const auto a = read_results(out / argv[3]);
    const auto b = read_results(out / argv[4]);
    double max_trans_m = 0.0, max_rot_deg = 0.0;
    // Per pair kind and setting: the medians of the total and of each stage, A then B.
    std::map<std::string, std::vector<double>> a_ms, b_ms;
    for (const auto& [name, ra] : a) {
        const auto it = b.find(name);
        if (it == b.end()) throw std::runtime_error(std::string(argv[4]) + ": no " + name);
        max_trans_m =
            std::max(max_trans_m, lidarfuse::core::translation_error_m(ra.T, it->second.T));
        max_rot_deg =
            std::max(max_rot_deg, lidarfuse::core::rotation_error_deg(ra.T, it->second.T));
        const std::string key =
            kind_of(name.substr(0, name.find('@'))) + "@" + name.substr(name.find('@') + 1);
        for (int stage = 0; stage < 5; ++stage) {
            const std::string stage_key = key + "_" + kStageNames[stage];
            a_ms[stage_key].push_back(stage < 4 ? ra.stage_ms[stage] : ra.total_ms);
            b_ms[stage_key].push_back(stage < 4 ? it->second.stage_ms[stage] : it->second.total_ms);
        }
    }
    print("gicp_pairs_compared", static_cast<double>(a.size()), "pairs");
    print("gicp_pairs_max_pose_difference", max_trans_m * 1e3, "mm");
    print("gicp_pairs_max_pose_difference", max_rot_deg, "deg");
    for (const auto& [key, v] : a_ms) {
        print("gicp_pairs_a_" + key, median(v), "ms");
        print("gicp_pairs_b_" + key, median(b_ms[key]), "ms");
        print("gicp_pairs_ratio_" + key, median(v) / median(b_ms[key]), "x");
    }
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
