// Our G-ICP against PCL's GeneralizedIterativeClosestPoint on the same pairs of simulated
// OS1-64 scans, with the same parameters (issue 4's comparison). Built only with
// -DLIDARFUSE_WITH_PCL=ON (needs Debian's libpcl-dev); never part of the test command.
//
// Pairs come from a `lidarfuse sim` capture (decoded with the production ingest) and its
// ground_truth.csv:
//   temporal: each sensor, frame k+1 onto frame k, started 0.1 m / 1 degree off the true
//             motion (the sway between two frames is millimetres, so a start at identity
//             would reward whichever stops first rather than whichever converges)
//   spatial:  each sensor onto the root sensor, same frame, started at the true pose
//             perturbed by 0.3 m and 2 degrees
// Both registrations get the same voxel-grid clouds, the same k for the covariances, the
// same correspondence bound, iteration cap and convergence thresholds, one thread each.
// Timed per pair: everything each needs from the two clouds (k-d trees, covariances,
// optimisation), because PCL computes its covariances inside align().
//
// Times are CPU time (ms), the fastest of 3 runs per pair, then the median over pairs.
//
// Also, per cloud, the covariance step alone (k-d tree, k nearest of every point,
// covariances), ours and PCL's, in us per point, and the per-point budget that a 5x
// "with covariances" would leave for it after our alignment (gicp_covariance_budget_*).
//
// Usage: gicp_pcl_bench [CAPTURE_DIR [FRAMES]]   (no CAPTURE_DIR: simulates the curve scene,
// seed 1, 4 sensors, into a temporary folder). Output: `name value unit` lines.
//
//        gicp_pcl_bench pairs OUT [REPETITIONS]
// PCL's own pipeline on the pairs that `gicp_pairs_bench write OUT` made (simulated and real,
// at 1 m and 0.25 m, each with its k, bound, iterations and epsilons): pcl::VoxelGrid, the
// FLANN k-d tree, GICP's covariances, its alignment with those trees and covariances, each
// stage's wall time the fastest of REPETITIONS (3), one thread. Writes the result file
// OUT/pcl_t1.txt, which `gicp_pairs_bench compare OUT ours_t1.txt pcl_t1.txt` sets beside
// ours stage by stage (bench/gicp_pair_files.hpp).

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#include <pcl/search/kdtree.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bench/pcl/gicp_pcl_pairs.hpp"
#include "bench/pcl/pcl_gicp_support.hpp"
#include "core/common/kdtree.hpp"
#include "core/common/se3.hpp"
#include "core/preprocess/normals.hpp"
#include "core/preprocess/voxel_grid.hpp"
#include "core/registration/gicp.hpp"
#include "drivers/capture/station_capture.hpp"
#include "drivers/io/pose_csv.hpp"
#include "drivers/station/station_config.hpp"

namespace {

namespace fs = std::filesystem;
using lidarfuse::bench::CountingGicp;
using lidarfuse::bench::to_pcl;
using lidarfuse::core::PointCloud;

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr int kCovarianceNeighbors = 20;  // PCL's default k_correspondences
constexpr int kMaxIterations = 30;
constexpr double kTranslationEpsM = 1e-4;
constexpr double kRotationEpsRad = 1e-4;
constexpr int kRepetitions = 3;

void print(const std::string& name, double value, const char* unit) {
    std::printf("%s %.6g %s\n", name.c_str(), value, unit);
}

// Process CPU time (ms), not wall-clock: the machine is shared, and CPU time is what a
// competing load does not inflate as much. Process-wide, so that any threads a library
// starts on its own would be counted too.
double cpu_ms() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

struct Pair {
    const char* kind;
    const std::vector<Eigen::Vector3d>* target;
    const std::vector<Eigen::Vector3d>* source;
    Eigen::Isometry3d T_true;  // T_target_source
    Eigen::Isometry3d T_init;
};

struct Outcome {
    double ms = 0.0, trans_err_m = 0.0, rot_err_deg = 0.0;
    int iterations = 0;
};

PointCloud downsample(const std::vector<Eigen::Vector3d>& points, double voxel_m) {
    lidarfuse::core::VoxelGrid grid;
    PointCloud out;
    grid.downsample(points, lidarfuse::core::VoxelGridParams{voxel_m, 1}, &out);
    return out;
}

lidarfuse::core::NormalParams covariance_params() {
    lidarfuse::core::NormalParams np;
    np.k_neighbors = kCovarianceNeighbors;
    np.compute_normals = false;
    return np;
}

// Both clouds of a pair with our covariances, when both sides get the same ones.
struct SharedClouds {
    lidarfuse::core::GicpCloud target, source;
};

// shared (not null): the clouds already carry covariances (the same ones go to PCL) and
// only the target's tree and the alignment are timed; otherwise the covariances are
// computed inside the timing.
Outcome run_ours(const PointCloud& target_in, const PointCloud& source_in,
                 const SharedClouds* shared, const Pair& pair, double max_corr_m) {
    lidarfuse::core::GicpParams gp;
    gp.max_correspondence_distance_m = max_corr_m;
    gp.max_iterations = kMaxIterations;
    gp.translation_eps_m = kTranslationEpsM;
    gp.rotation_eps_rad = kRotationEpsRad;

    using lidarfuse::core::GicpCloud;
    PointCloud target = target_in, source = source_in;
    lidarfuse::core::CovarianceByproducts target_byproducts;
    if (shared) target_byproducts = shared->target.byproducts();
    const double start = cpu_ms();
    // Each cloud's covariances on its own k-d tree (as the daemon and calibrate do).
    const GicpCloud gicp_target = shared
                                      ? GicpCloud(std::move(target), std::move(target_byproducts))
                                      : GicpCloud(std::move(target), covariance_params());
    const GicpCloud fresh_source =
        shared ? GicpCloud() : GicpCloud(std::move(source), covariance_params());
    const lidarfuse::core::GicpResult r = lidarfuse::core::align_gicp(
        gicp_target, shared ? shared->source : fresh_source, pair.T_init, gp);
    Outcome o;
    o.ms = cpu_ms() - start;
    o.iterations = r.iterations;
    o.trans_err_m = lidarfuse::core::translation_error_m(r.T_target_source, pair.T_true);
    o.rot_err_deg = lidarfuse::core::rotation_error_deg(r.T_target_source, pair.T_true);
    return o;
}

// Per-point CPU time (us) of the covariance step alone on one cloud, ours and PCL's, each
// the fastest of kRepetitions: the k-d tree and the k nearest of every point (`knn`), and
// the whole step, tree to covariances. It is what a pair "with covariances" adds to the
// alignment, once per cloud.
struct CovarianceCost {
    double ours_knn_us = 0.0, ours_us = 0.0, pcl_knn_us = 0.0, pcl_us = 0.0;
};

CovarianceCost covariance_cost(const PointCloud& cloud) {
    const double n = static_cast<double>(cloud.size());
    const auto fastest_us_per_point = [n](const auto& step) {
        double fastest = 1e300;
        for (int r = 0; r < kRepetitions; ++r) {
            const double start = cpu_ms();
            step();
            fastest = std::min(fastest, (cpu_ms() - start) * 1e3 / n);
        }
        return fastest;
    };
    const auto pcl_cloud = to_pcl(cloud.points);
    CovarianceCost c;
    c.ours_knn_us = fastest_us_per_point([&] {
        std::uint32_t idx[kCovarianceNeighbors];
        double d2[kCovarianceNeighbors];
        const lidarfuse::core::KdTree tree(cloud.points);
        for (const Eigen::Vector3d& p : cloud.points) tree.knn(p, kCovarianceNeighbors, idx, d2);
    });
    std::vector<PointCloud> copies(kRepetitions, cloud);  // a fresh cloud for every run
    std::size_t run = 0;
    c.ours_us = fastest_us_per_point([&] {
        lidarfuse::core::estimate_normals_covariances(&copies[run++], covariance_params());
    });
    pcl::Indices idx;
    std::vector<float> d2;
    c.pcl_knn_us = fastest_us_per_point([&] {
        auto tree = pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
        tree->setInputCloud(pcl_cloud);
        for (const pcl::PointXYZ& p : pcl_cloud->points)
            tree->nearestKSearch(p, kCovarianceNeighbors, idx, d2);
    });
    CountingGicp gicp;
    gicp.setCorrespondenceRandomness(kCovarianceNeighbors);
    CountingGicp::MatricesVector covariances;
    c.pcl_us = fastest_us_per_point([&] {
        auto tree = pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
        tree->setInputCloud(pcl_cloud);
        gicp.covariances(pcl_cloud, tree, &covariances);
    });
    return c;
}

CountingGicp::MatricesVectorPtr to_pcl_covariances(const PointCloud& cloud) {
    auto out = pcl::make_shared<CountingGicp::MatricesVector>(cloud.covariances.begin(),
                                                              cloud.covariances.end());
    return out;
}

Outcome run_pcl(const PointCloud& target_in, const PointCloud& source_in, const Pair& pair,
                double max_corr_m, bool shared_covariances) {
    const auto target = to_pcl(target_in.points);
    const auto source = to_pcl(source_in.points);
    CountingGicp::MatricesVectorPtr target_cov, source_cov;
    if (shared_covariances) {
        target_cov = to_pcl_covariances(target_in);
        source_cov = to_pcl_covariances(source_in);
    }
    CountingGicp gicp;
    gicp.setCorrespondenceRandomness(kCovarianceNeighbors);
    gicp.setMaxCorrespondenceDistance(max_corr_m);
    gicp.setMaximumIterations(kMaxIterations);
    // GICP compares these with the change of each matrix element per outer iteration:
    // metres for the translation column, ~radians for the rotation block.
    gicp.setTransformationEpsilon(kTranslationEpsM);
    gicp.setRotationEpsilon(kRotationEpsRad);
    pcl::PointCloud<pcl::PointXYZ> aligned;
    const double start = cpu_ms();
    gicp.setInputTarget(target);
    gicp.setInputSource(source);
    if (shared_covariances) {
        gicp.setTargetCovariances(target_cov);
        gicp.setSourceCovariances(source_cov);
    }
    gicp.align(aligned, pair.T_init.matrix().cast<float>());
    Outcome o;
    o.ms = cpu_ms() - start;
    Eigen::Isometry3d T(gicp.getFinalTransformation().cast<double>());
    // Re-orthonormalise the float rotation before comparing.
    const Eigen::Quaterniond q(T.linear());
    T.linear() = q.normalized().toRotationMatrix();
    o.iterations = gicp.iterations();
    o.trans_err_m = lidarfuse::core::translation_error_m(T, pair.T_true);
    o.rot_err_deg = lidarfuse::core::rotation_error_deg(T, pair.T_true);
    return o;
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

// FRAMES (4 without it); 0 after saying why it is refused: a temporal pair takes two scans
// of a sensor.
std::size_t frames_argument(int argc, char** argv) {
    const int frames = argc > 2 ? std::atoi(argv[2]) : 4;
    if (frames >= 2) return static_cast<std::size_t>(frames);
    std::fprintf(stderr,
                 "gicp_pcl_bench: FRAMES must be 2 or more (a temporal pair takes two "
                 "scans of a sensor), got \"%s\"\n",
                 argv[2]);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc > 2 && std::string(argv[1]) == "pairs") {
        try {
            return lidarfuse::bench::run_pcl_pairs(argv[2],
                                                   argc > 3 ? std::max(1, std::atoi(argv[3])) : 3);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "gicp_pcl_bench: %s\n", e.what());
            return 1;
        }
    }
    fs::path dir;
    fs::path temporary;
    if (argc > 1) {
        dir = argv[1];
    } else {
        temporary =
            fs::temp_directory_path() / ("lidarfuse_gicp_pcl_" + std::to_string(::getpid()));
        dir = temporary;
        const std::string cmd = std::string("\"") + LIDARFUSE_TOOL_PATH +
                                "\" sim --scenario curve --seed 1 --seconds 0.4 --out \"" +
                                dir.string() + "\" > /dev/null";
        if (std::system(cmd.c_str()) != 0) {
            std::fprintf(stderr, "gicp_pcl_bench: %s failed\n", cmd.c_str());
            return 1;
        }
    }
    const std::size_t frames = frames_argument(argc, argv);
    if (frames == 0) return 1;

    const auto station = lidarfuse::station::load_station_config(dir / "station.yaml");
    lidarfuse::capture::StationCapture capture(station, dir / "capture.pcap");
    const std::size_t n = station.sensors.size();
    std::vector<std::vector<std::vector<Eigen::Vector3d>>> scans(n);  // [sensor][frame]
    capture.run([&](const lidarfuse::capture::CaptureScan& s) {
        if (scans[s.sensor].size() < frames) scans[s.sensor].push_back(s.cloud->cloud.points);
        return true;
    });
    // Ground truth per sensor, in frame order.
    std::map<std::string, std::vector<Eigen::Isometry3d>> truth;
    for (const auto& r : lidarfuse::io::read_pose_csv(dir / "ground_truth.csv")) {
        truth[r.sensor].push_back(r.pose);
    }

    std::vector<Pair> pairs;
    lidarfuse::core::Vector6d nudge, small_nudge;  // rotation (rad) then translation (m)
    nudge << 2.0 * kDeg, 0.0, 0.0, 0.3, 0.0, 0.0;
    small_nudge << 0.0, 0.0, 1.0 * kDeg, 0.0, 0.1, 0.0;
    for (std::size_t s = 0; s < n; ++s) {
        const auto& gt = truth.at(station.sensors[s].name);
        const auto& root_gt = truth.at(station.sensors[0].name);
        for (std::size_t k = 0; k + 1 < scans[s].size() && k + 1 < gt.size(); ++k) {
            const Eigen::Isometry3d T_motion = gt[k].inverse() * gt[k + 1];
            pairs.push_back({"temporal", &scans[s][k], &scans[s][k + 1], T_motion,
                             T_motion * lidarfuse::core::se3_exp(small_nudge)});
            if (s > 0 && k < scans[0].size()) {
                const Eigen::Isometry3d T_true = root_gt[k].inverse() * gt[k];
                pairs.push_back({"spatial", &scans[0][k], &scans[s][k], T_true,
                                 T_true * lidarfuse::core::se3_exp(nudge)});
            }
        }
    }
    print("gicp_pcl_pairs", static_cast<double>(pairs.size()), "pairs");

    for (const double voxel_m : {1.0, 0.5}) {
        const double max_corr_m = 2.0 * voxel_m;
        char voxel_tag[24];
        std::snprintf(voxel_tag, sizeof(voxel_tag), "voxel%gm", voxel_m);
        // The covariance step per cloud, on every scan the pairs use.
        std::vector<double> knn_ours, cov_ours, knn_pcl, cov_pcl, points;
        for (const auto& sensor_scans : scans) {
            for (const auto& scan : sensor_scans) {
                const PointCloud cloud = downsample(scan, voxel_m);
                const CovarianceCost c = covariance_cost(cloud);
                knn_ours.push_back(c.ours_knn_us);
                cov_ours.push_back(c.ours_us);
                knn_pcl.push_back(c.pcl_knn_us);
                cov_pcl.push_back(c.pcl_us);
                points.push_back(static_cast<double>(cloud.size()));
            }
        }
        const std::string cost = std::string("gicp_covariance_") + voxel_tag;
        print(cost + "_median_points", median(points), "points");
        print(cost + "_ours_knn_median_per_point", median(knn_ours), "us");
        print(cost + "_pcl_knn_median_per_point", median(knn_pcl), "us");
        print(cost + "_ours_median_per_point", median(cov_ours), "us");
        print(cost + "_pcl_median_per_point", median(cov_pcl), "us");
        std::map<std::string, double> align_ms;  // ours, alignment alone, per kind
        for (const bool shared : {true, false}) {
            std::map<std::string, std::vector<Outcome>> ours, theirs;
            for (const Pair& p : pairs) {
                PointCloud target = downsample(*p.target, voxel_m);
                PointCloud source = downsample(*p.source, voxel_m);
                std::optional<SharedClouds> clouds;
                if (shared) {
                    using lidarfuse::core::GicpCloud;
                    clouds = SharedClouds{GicpCloud(std::move(target), covariance_params()),
                                          GicpCloud(std::move(source), covariance_params())};
                    target = clouds->target.cloud_with_covariance_matrices();
                    source = clouds->source.cloud_with_covariance_matrices();
                }
                const SharedClouds* ours_shared = clouds ? &*clouds : nullptr;
                // Fastest of kRepetitions: the least disturbed by whatever else runs.
                Outcome a = run_ours(target, source, ours_shared, p, max_corr_m);
                Outcome b = run_pcl(target, source, p, max_corr_m, shared);
                for (int r = 1; r < kRepetitions; ++r) {
                    a.ms = std::min(a.ms, run_ours(target, source, ours_shared, p, max_corr_m).ms);
                    b.ms = std::min(b.ms, run_pcl(target, source, p, max_corr_m, shared).ms);
                }
                ours[p.kind].push_back(a);
                theirs[p.kind].push_back(b);
            }
            char tag[48];
            std::snprintf(tag, sizeof(tag), "voxel%gm_%s", voxel_m, shared ? "align" : "full");
            for (const char* kind : {"temporal", "spatial"}) {
                auto figures = [&](const char* who, const std::vector<Outcome>& v) {
                    std::vector<double> ms, te, re, it;
                    for (const Outcome& o : v) {
                        ms.push_back(o.ms);
                        te.push_back(o.trans_err_m * 100.0);
                        re.push_back(o.rot_err_deg);
                        it.push_back(o.iterations);
                    }
                    const std::string prefix = std::string("gicp_") + who + "_" + tag + "_" + kind;
                    print(prefix + "_median_time", median(ms), "ms");
                    print(prefix + "_median_trans_error", median(te), "cm");
                    print(prefix + "_max_trans_error", *std::max_element(te.begin(), te.end()),
                          "cm");
                    print(prefix + "_median_rot_error", median(re), "deg");
                    print(prefix + "_max_rot_error", *std::max_element(re.begin(), re.end()),
                          "deg");
                    print(prefix + "_median_iterations", median(it), "iterations");
                    return median(ms);
                };
                const double ours_ms = figures("ours", ours[kind]);
                const double pcl_ms = figures("pcl", theirs[kind]);
                print(std::string("gicp_speedup_") + tag + "_" + kind, pcl_ms / ours_ms, "x");
                if (shared) {
                    align_ms[kind] = ours_ms;
                } else {
                    // What 5x with covariances leaves for the covariance step of the two
                    // clouds, per point, after our alignment alone (the shared run).
                    const double budget_us =
                        (pcl_ms / 5.0 - align_ms[kind]) * 1e3 / (2.0 * median(points));
                    print(std::string("gicp_covariance_budget_for_5x_") + voxel_tag + "_" + kind,
                          budget_us, "us");
                }
            }
        }
    }
    if (!temporary.empty()) fs::remove_all(temporary);
    return 0;
}
