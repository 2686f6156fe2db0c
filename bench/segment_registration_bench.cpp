// Registering two stations of a road segment to each other from nothing (issue 20), offline
// and against the simulator's truth: each station's fused cloud in its own road frame, the
// placement found by core/initial/road_grid_search.hpp, its error. Prints `name value unit`
// lines per case. bench/segment_registration_check.sh makes the cases.
//
// Usage: segment_registration_bench THREADS FRAME CASE...
//   CASE: a folder holding S/ (`lidarfuse sim --stations 2 ...`) and F0/, F1/ (`lidarfuse
//   fuse S/station<j>/capture.pcap ... --world road --save-cloud FRAME`).
// Or:    segment_registration_bench truth STATION_SIM STATION_POSES NAME
//   prints ground-truth rows (poses.csv format) of a station's road frame in the
//   simulator's world, named NAME, at every stamp of its root (lidar0) in STATION_SIM's
//   ground_truth.csv: its road frame (fixed once) from STATION_POSES (the station's
//   poses.csv), for `lidarfuse eval` of a segment daemon (bench/segment_run.sh).

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/common/angles.hpp"
#include "core/common/se3.hpp"
#include "core/initial/initial_registration.hpp"
#include "core/initial/road_grid_search.hpp"
#include "drivers/io/cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"

using namespace lidarfuse;
namespace fs = std::filesystem;

namespace {

Eigen::Isometry3d pose_at(const fs::path& csv, std::int64_t frame, const std::string& sensor) {
    for (const auto& r : io::read_pose_csv(csv)) {
        if (r.frame == frame && r.sensor == sensor) return r.pose;
    }
    throw std::runtime_error(csv.string() + ": no row of " + sensor + " at frame " +
                             std::to_string(frame));
}

// A station's road frame in the simulator's world: its root's true pose at `frame` times
// the inverse of the fused (road) frame's estimate of it.
Eigen::Isometry3d world_from_road(const fs::path& truth_csv, const fs::path& poses_csv,
                                  std::int64_t frame) {
    return pose_at(truth_csv, frame, "lidar0") * pose_at(poses_csv, frame, "lidar0").inverse();
}

Eigen::Isometry3d world_from_road(const fs::path& dir, int j, std::int64_t frame) {
    const std::string s = std::to_string(j);
    return world_from_road(dir / "S" / ("station" + s) / "ground_truth.csv",
                           dir / ("F" + s) / "poses.csv", frame);
}

// The road frame from the station's last pose row of lidar0 (its estimate settled) and the
// truth of the same scan (same stamp: a daemon's frame numbers are not the capture's).
void print_truth(const fs::path& sim, const fs::path& poses_csv, const std::string& name) {
    io::PoseRecord last;
    for (const auto& r : io::read_pose_csv(poses_csv)) {
        if (r.sensor == "lidar0" && r.t_ns > last.t_ns) last = r;
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    bool found = false;
    for (const auto& r : io::read_pose_csv(sim / "ground_truth.csv")) {
        if (r.sensor != "lidar0" || r.t_ns != last.t_ns) continue;
        T = r.pose * last.pose.inverse();
        found = true;
    }
    if (!found) throw std::runtime_error(poses_csv.string() + ": no scan of lidar0 in the truth");
    const Eigen::Quaterniond q(T.linear());
    std::printf("%s\n", io::kPoseCsvHeader);
    for (const auto& r : io::read_pose_csv(sim / "ground_truth.csv")) {
        if (r.sensor != "lidar0") continue;
        std::printf("%lld,%s,%lld,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f\n",
                    static_cast<long long>(r.frame), name.c_str(), static_cast<long long>(r.t_ns),
                    T.translation().x(), T.translation().y(), T.translation().z(), q.w(), q.x(),
                    q.y(), q.z());
    }
}

double yaw_deg(const Eigen::Isometry3d& T) {
    return std::abs(std::atan2(T.linear()(1, 0), T.linear()(0, 0))) * 180.0 / core::kPi;
}

void run_case(const fs::path& dir, std::int64_t frame, int threads) {
    const std::string name = "segment_" + dir.filename().string();
    const std::string ply = "fused_" + std::to_string(frame) + ".ply";
    const auto target = io::read_cloud_file(dir / "F0" / ply).cloud.points;
    const auto source = io::read_cloud_file(dir / "F1" / ply).cloud.points;
    const Eigen::Isometry3d truth =
        world_from_road(dir, 0, frame).inverse() * world_from_road(dir, 1, frame);
    const auto start = std::chrono::steady_clock::now();
    const core::RoadGridPlacement placement = core::search_road_grid(target, source, {}, threads);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    std::printf("%s_found %d flag\n", name.c_str(), placement.found ? 1 : 0);
    std::printf("%s_score %.0f cells\n", name.c_str(), placement.score);
    std::printf("%s_rival_share %.3f ratio\n", name.c_str(),
                placement.score > 0 ? placement.rival_score / placement.score : 0.0);
    std::printf("%s_search_time %.1f ms\n", name.c_str(), ms);
    if (!placement.found) {
        std::fprintf(stderr, "%s: refused: %s\n", name.c_str(), placement.why.c_str());
        return;
    }
    const Eigen::Isometry3d grid_error = truth.inverse() * placement.T_target_source;
    std::printf("%s_grid_error_horizontal %.3f m\n", name.c_str(),
                grid_error.translation().head<2>().norm());
    std::printf("%s_grid_error_yaw %.3f deg\n", name.c_str(), yaw_deg(grid_error));
    core::InitialRegistrationParams params = core::default_initial_registration_params();
    params.method = core::InitialRegistrationMethod::kStations;
    core::PointCloud a, b;
    a.points = target;
    b.points = source;
    const auto registered = core::register_initial({a, b}, params, threads);
    std::printf("%s_registered %d flag\n", name.c_str(), registered.sensors[1].registered ? 1 : 0);
    std::printf("%s_registration_time %.1f ms\n", name.c_str(), registered.timings.total_s * 1e3);
    if (!registered.sensors[1].registered) return;
    const Eigen::Isometry3d error = truth.inverse() * registered.sensors[1].T_root_sensor;
    std::printf("%s_error %.3f m\n", name.c_str(),
                core::translation_error_m(registered.sensors[1].T_root_sensor, truth));
    std::printf("%s_error_rotation %.3f deg\n", name.c_str(),
                core::rotation_error_deg(registered.sensors[1].T_root_sensor, truth));
    std::printf("%s_error_yaw %.3f deg\n", name.c_str(), yaw_deg(error));
    // Between the two road frames' up axes: roll and pitch together.
    std::printf("%s_error_tilt %.3f deg\n", name.c_str(),
                std::acos(std::min(1.0, error.linear()(2, 2))) * 180.0 / core::kPi);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 4) {
        std::fprintf(stderr, "usage: %s THREADS FRAME CASE...\n", argv[0]);
        return 2;
    }
    if (std::string(argv[1]) == "truth" && argc == 5) {
        try {
            print_truth(argv[2], argv[3], argv[4]);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "segment_registration_bench: %s\n", e.what());
            return 1;
        }
        return 0;
    }
    const int threads = std::atoi(argv[1]);
    const std::int64_t frame = std::atoll(argv[2]);
    try {
        for (int i = 3; i < argc; ++i) run_case(argv[i], frame, threads);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "segment_registration_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
