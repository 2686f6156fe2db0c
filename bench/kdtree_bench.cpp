// Our k-d tree (core/common/kdtree.hpp) against nanoflann 1.4.3 (Debian's libnanoflann-dev, the
// tree core/ used before) on the searches a frame of continuous registration makes, on
// simulated OS1-64 scans decoded with the production ingest:
//   build      the tree over one voxelised scan;
//   knn        each point's k nearest in its own cloud (the G-ICP covariances, k = 6 at 1 m),
//              ours in its leaf order (as estimate_normals_covariances asks);
//   nearest    each point of the next scan's nearest within 2 voxels (G-ICP correspondences,
//              the bound G-ICP starts from);
//   *_scan     the same on whole scans (the initial registration's clouds): k = 15, 1 m;
//   build_full the tree over a whole scan with 1 and 2 threads (ours only: nanoflann 1.4.3
//              builds serially).
// Both trees answer every query; the bench checks that they agree (same index and distance).
// Rounds alternate ours and nanoflann so that both see the same machine.
//
// Output: `name value unit` lines, process CPU time per point.
// Usage: kdtree_bench [CAPTURE_DIR [ROUNDS]]   (no capture: simulates curve seed 1, 0.3 s)

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>
#include <nanoflann.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/common/kdtree.hpp"
#include "core/preprocess/voxel_grid.hpp"
#include "drivers/capture/station_capture.hpp"
#include "drivers/station/station_config.hpp"

namespace {

namespace fs = std::filesystem;
using Points = std::vector<Eigen::Vector3d>;

struct Adaptor {
    const Points* points;
    std::size_t kdtree_get_point_count() const { return points->size(); }
    double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*points)[i][dim]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
        return false;
    }
};
using Nanoflann = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>,
                                                      Adaptor, 3, std::uint32_t>;

// nanoflann's 1-nearest with a start bound (the same result set core/ used with it); the
// method names are the ones nanoflann's result-set interface calls.
class BoundedNearest {
public:
    explicit BoundedNearest(double bound) : best_(bound) {}
    std::size_t size() const { return found_ ? 1 : 0; }
    bool full() const { return true; }
    bool addPoint(double d2, std::uint32_t i) {  // NOLINT(readability-identifier-naming)
        if (d2 < best_) best_ = d2, index_ = i, found_ = true;
        return true;
    }
    double worstDist() const { return best_; }  // NOLINT(readability-identifier-naming)
    std::uint32_t index_ = 0;
    double best_;
    bool found_ = false;
};

double cpu_s() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double timed(const std::function<void()>& work) {
    const double t0 = cpu_s();
    work();
    return cpu_s() - t0;
}

struct Scene {
    std::vector<Points> full;   // whole scans, sensor frame
    std::vector<Points> cloud;  // the same at the voxel size
};

Scene load(const fs::path& dir, double voxel_m) {
    const auto station = lidarfuse::station::load_station_config(dir / "station.yaml");
    lidarfuse::capture::StationCapture capture(station, dir / "capture.pcap");
    Scene scene;
    capture.run([&](const lidarfuse::capture::CaptureScan& s) {
        if (s.sensor == 0) scene.full.push_back(s.cloud->cloud.points);
        return true;
    });
    lidarfuse::core::VoxelGridParams params;
    params.voxel_size_m = voxel_m;
    for (const auto& scan : scene.full) {
        scene.cloud.push_back(voxel_m > 0 ? lidarfuse::core::voxel_downsample(scan, params).points
                                          : scan);
    }
    return scene;
}

struct Totals {
    double ours = 0, theirs = 0;
    std::size_t points = 0;
    void print(const char* name) const {
        std::printf("kdtree_%s_ours %.4f us_per_point\n", name,
                    1e6 * ours / static_cast<double>(points));
        std::printf("kdtree_%s_nanoflann %.4f us_per_point\n", name,
                    1e6 * theirs / static_cast<double>(points));
        std::printf("kdtree_%s_speedup %.2f x\n", name, theirs / ours);
    }
};

int g_mismatches = 0;
void agree(std::uint32_t a, double da, std::uint32_t b, double db) {
    if (a != b || da != db) ++g_mismatches;
}

// One round over every consecutive pair of clouds.
// Whole scans (voxel 0): k = 15 and a 1 m bound, as the initial registration's normals and
// p2p checks use them.
void round(const Scene& scene, double voxel_m, Totals* build, Totals* knn, Totals* nearest) {
    const std::size_t k = voxel_m > 0 ? 6 : 15;
    const double bound = voxel_m > 0 ? 4.0 * voxel_m * voxel_m : 1.0;
    for (std::size_t f = 0; f + 1 < scene.cloud.size(); ++f) {
        const Points& target = scene.cloud[f];
        const Points& source = scene.cloud[f + 1];
        std::vector<std::uint32_t> ia(target.size() * k), ib(target.size() * k);
        std::vector<double> da(target.size() * k), db(target.size() * k);
        std::vector<std::uint32_t> na(source.size()), nb(source.size());
        std::vector<double> ea(source.size(), -1), eb(source.size(), -1);
        std::unique_ptr<lidarfuse::core::KdTree> ours;
        build->ours += timed([&] { ours = std::make_unique<lidarfuse::core::KdTree>(target); });
        knn->ours += timed([&] {
            for (const std::uint32_t i : ours->leaf_order())
                ours->knn(target[i], k, &ia[i * k], &da[i * k]);
        });
        nearest->ours += timed([&] {
            for (std::size_t i = 0; i < source.size(); ++i)
                ours->nearest_within(source[i], bound, &na[i], &ea[i]);
        });
        Adaptor adaptor{&target};
        std::unique_ptr<Nanoflann> theirs;
        build->theirs += timed([&] {
            theirs = std::make_unique<Nanoflann>(3, adaptor,
                                                 nanoflann::KDTreeSingleIndexAdaptorParams(10));
        });
        knn->theirs += timed([&] {
            for (std::size_t i = 0; i < target.size(); ++i) {
                nanoflann::KNNResultSet<double, std::uint32_t> result(k);
                result.init(&ib[i * k], &db[i * k]);
                theirs->findNeighbors(result, target[i].data(), nanoflann::SearchParams());
            }
        });
        nearest->theirs += timed([&] {
            for (std::size_t i = 0; i < source.size(); ++i) {
                BoundedNearest result(bound);
                theirs->findNeighbors(result, source[i].data(), nanoflann::SearchParams());
                if (result.found_) nb[i] = result.index_, eb[i] = result.best_;
            }
        });
        for (std::size_t i = 0; i < ia.size(); ++i) agree(ia[i], da[i], ib[i], db[i]);
        for (std::size_t i = 0; i < na.size(); ++i) {
            if (ea[i] >= 0 || eb[i] >= 0) agree(na[i], ea[i], nb[i], eb[i]);
        }
        build->points += target.size();
        knn->points += target.size();
        nearest->points += source.size();
    }
}

void full_builds(const Scene& scene, int rounds) {
    for (int threads : {1, 2}) {
        double cpu = 0, wall = 0;
        std::size_t points = 0;
        for (int r = 0; r < rounds; ++r) {
            for (const auto& scan : scene.full) {
                const auto t0 = std::chrono::steady_clock::now();
                cpu += timed([&] { lidarfuse::core::KdTree tree(scan, 10, threads); });
                wall +=
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                points += scan.size();
            }
        }
        std::printf("kdtree_build_full_%dthreads_wall %.4f us_per_point\n", threads,
                    1e6 * wall / static_cast<double>(points));
        std::printf("kdtree_build_full_%dthreads_cpu %.4f us_per_point\n", threads,
                    1e6 * cpu / static_cast<double>(points));
    }
}

// A short simulated capture in a temporary folder (removed by main), when none is given.
fs::path simulated_capture() {
    const fs::path out =
        fs::temp_directory_path() / ("lidarfuse_kdtree_" + std::to_string(::getpid()));
    const std::string sim = std::string("\"") + LIDARFUSE_TOOL_PATH +
                            "\" sim --scenario curve --seed 1 --seconds 0.3 --quiet --out \"" +
                            out.string() + "\" > /dev/null";
    if (std::system(sim.c_str()) != 0) throw std::runtime_error("kdtree_bench: " + sim + " failed");
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    const bool simulated = argc < 2;
    const fs::path dir = simulated ? simulated_capture() : fs::path(argv[1]);
    const int rounds = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
    for (const double voxel_m : {1.0, 3.0, 0.0}) {
        const Scene scene = load(dir, voxel_m);
        Totals build, knn, nearest;
        for (int r = 0; r < rounds; ++r) round(scene, voxel_m, &build, &knn, &nearest);
        const std::string suffix =
            voxel_m > 0 ? "_" + std::to_string(static_cast<int>(voxel_m)) + "m" : "_scan";
        std::printf("kdtree_cloud_points%s %.0f points\n", suffix.c_str(),
                    static_cast<double>(build.points) / (rounds * (scene.cloud.size() - 1.0)));
        build.print(("build" + suffix).c_str());
        knn.print(("knn" + suffix).c_str());
        nearest.print(("nearest" + suffix).c_str());
        if (voxel_m == 1.0) full_builds(scene, rounds);
    }
    std::printf("kdtree_disagreements %d queries\n", g_mismatches);
    if (simulated) fs::remove_all(dir);
    return g_mismatches == 0 ? 0 : 2;
}
