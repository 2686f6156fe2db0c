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
// Or:    segment_registration_bench track CONFIG FIRST LAST CASE [THIN_M]
//   the segment's continuous registration offline: a FusionEngine of two sensors, station0
//   (root) and station1, with CONFIG's registration section (a segment's station.yaml),
//   fed frame k = FIRST..LAST with F0/ and F1/'s fused_<k>.ply at each station's own stamp
//   of frame k, as the segment daemon takes them from DDS (points only: no deskew), or
//   thinned to THIN_M voxels first as a station's points_voxel topic carries them; prints
//   station1's strict RMSE (translation, rotation, tilt) against the truth over the
//   registered frames. The same as bench/segment_run.sh without the daemons' timing.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/common/angles.hpp"
#include "core/common/se3.hpp"
#include "core/initial/initial_registration.hpp"
#include "core/initial/road_grid_search.hpp"
#include "core/pipeline/fused_cloud_voxels.hpp"
#include "core/pipeline/fusion_engine.hpp"
#include "drivers/io/cloud_file.hpp"
#include "drivers/io/fused_cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"
#include "drivers/station/fusion_config.hpp"

using namespace lidarfuse;
namespace fs = std::filesystem;

namespace {

// Pose rows by (frame, sensor), from poses.csv or ground_truth.csv.
using PoseTable = std::map<std::pair<std::int64_t, std::string>, io::PoseRecord>;

PoseTable pose_table(const fs::path& csv) {
    PoseTable table;
    for (auto& r : io::read_pose_csv(csv)) table[{r.frame, r.sensor}] = r;
    return table;
}

const io::PoseRecord& row(const PoseTable& table, std::int64_t frame, const std::string& sensor,
                          const fs::path& csv) {
    const auto it = table.find({frame, sensor});
    if (it == table.end()) {
        throw std::runtime_error(csv.string() + ": no row of " + sensor + " at frame " +
                                 std::to_string(frame));
    }
    return it->second;
}

// One station of a case: its estimates (F<j>/poses.csv, in its road frame) and its truth.
struct StationRun {
    fs::path poses_csv, truth_csv, clouds;
    PoseTable poses, truth;
    std::vector<std::string> sensors;  // every sensor of the station, in name order
};

StationRun station_run(const fs::path& dir, int j) {
    const std::string s = std::to_string(j);
    StationRun run;
    run.clouds = dir / ("F" + s);
    run.poses_csv = run.clouds / "poses.csv";
    run.truth_csv = dir / "S" / ("station" + s) / "ground_truth.csv";
    run.poses = pose_table(run.poses_csv);
    run.truth = pose_table(run.truth_csv);
    for (const auto& [key, r] : run.poses) {
        if (key.first == run.poses.begin()->first.first) run.sensors.push_back(key.second);
    }
    std::sort(run.sensors.begin(), run.sensors.end());
    return run;
}

// The station's road frame in the simulator's world at frame k as one sensor's true pose
// times the inverse of the fused (road) frame's estimate of it. The station's truth is
// lidar0's.
Eigen::Isometry3d world_from_road(const StationRun& run, std::int64_t k,
                                  const std::string& sensor = "lidar0") {
    return row(run.truth, k, sensor, run.truth_csv).pose *
           row(run.poses, k, sensor, run.poses_csv).pose.inverse();
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

// Between two road frames' up axes: roll and pitch together.
double tilt_deg(const Eigen::Isometry3d& error) {
    return std::acos(std::min(1.0, error.linear()(2, 2))) * 180.0 / core::kPi;
}

void run_case(const fs::path& dir, std::int64_t frame, int threads) {
    const std::string name = "segment_" + dir.filename().string();
    const std::string ply = "fused_" + std::to_string(frame) + ".ply";
    const auto target = io::read_cloud_file(dir / "F0" / ply).cloud.points;
    const auto source = io::read_cloud_file(dir / "F1" / ply).cloud.points;
    const Eigen::Isometry3d truth = world_from_road(station_run(dir, 0), frame).inverse() *
                                    world_from_road(station_run(dir, 1), frame);
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
    std::printf("%s_error_tilt %.3f deg\n", name.c_str(), tilt_deg(error));
}

// Station j's fused cloud of frame k at its root's stamp, as the segment daemon's DDS input
// hands it over (points only); thin_m > 0: as output.dds.points_voxel_size_m thins it.
core::SensorScanInput station_scan(const StationRun& run, std::int64_t k, double thin_m) {
    core::SensorScanInput scan;
    scan.present = true;
    scan.t_ns = row(run.poses, k, "lidar0", run.poses_csv).t_ns;
    core::FusedCloud cloud =
        io::read_fused_cloud_ply(run.clouds / ("fused_" + std::to_string(k) + ".ply"));
    if (thin_m > 0) {
        core::FusedCloud thinned;
        core::FusedCloudVoxels().downsample(cloud, thin_m, &thinned);
        cloud = std::move(thinned);
    }
    scan.points = std::move(cloud.points);
    return scan;
}

// Squared errors summed over the frames, RMSE printed.
struct ErrorSum {
    double trans = 0, rot = 0, tilt = 0;
    int n = 0;
    void add(const Eigen::Isometry3d& pose, const Eigen::Isometry3d& truth) {
        trans += std::pow(core::translation_error_m(pose, truth), 2);
        rot += std::pow(core::rotation_error_deg(pose, truth), 2);
        tilt += std::pow(tilt_deg(truth.inverse() * pose), 2);
        ++n;
    }
    void add(const ErrorSum& other) {
        trans += other.trans, rot += other.rot, tilt += other.tilt, n += other.n;
    }
    void print(const std::string& name) const {
        if (n == 0) return;
        std::printf("%s_strict_rmse_trans %.4f m\n", name.c_str(), std::sqrt(trans / n));
        std::printf("%s_strict_rmse_rot %.4f deg\n", name.c_str(), std::sqrt(rot / n));
        std::printf("%s_strict_rmse_tilt %.4f deg\n", name.c_str(), std::sqrt(tilt / n));
    }
};

// Station1's frame in the segment, and every sensor of station1 in the segment's root
// sensor (station0's lidar0) frame: the segment's placement composed with station1's own
// estimates, against the truth of the same scans. The station's frame truth rests on its
// lidar0 alone; the sensors' errors are what a user of the segment's tf tree gets.
void track_case(const fs::path& config, std::int64_t first, std::int64_t last, const fs::path& dir,
                double thin_m) {
    core::FusionParams params = station::load_fusion_params(config);
    params.root_sensor = 0;
    params.initial_registration_inline = true;
    params.build_fused_cloud = false;
    params.num_threads = 2;
    core::FusionEngine engine(2, params);
    const StationRun s0 = station_run(dir, 0), s1 = station_run(dir, 1);
    ErrorSum station, spread;
    std::map<std::string, ErrorSum> sensors;
    double total_ms = 0;
    for (std::int64_t k = first; k <= last; ++k) {
        core::FrameInput input;
        input.sensors = {station_scan(s0, k, thin_m), station_scan(s1, k, thin_m)};
        const core::FrameOutput out = engine.process(input);
        if (out.health[1].state != core::TrackState::kTracking) continue;
        const Eigen::Isometry3d& segment_pose = out.T_root_sensor[1];
        station.add(segment_pose, world_from_road(s0, k).inverse() * world_from_road(s1, k));
        const Eigen::Isometry3d root_from_segment =
            row(s0.poses, k, "lidar0", s0.poses_csv).pose.inverse();
        const Eigen::Isometry3d root_truth = row(s0.truth, k, "lidar0", s0.truth_csv).pose;
        for (const auto& name : s1.sensors) {
            sensors[name].add(
                root_from_segment * segment_pose * row(s1.poses, k, name, s1.poses_csv).pose,
                root_truth.inverse() * row(s1.truth, k, name, s1.truth_csv).pose);
        }
        for (const StationRun* run : {&s0, &s1}) {
            for (const auto& sensor : run->sensors) {
                spread.add(world_from_road(*run, k, sensor), world_from_road(*run, k));
            }
        }
        total_ms += out.timings.total_ms;
    }
    const std::string name = "segment_track_" + dir.filename().string();
    std::printf("%s_frames_tracked %d frames\n", name.c_str(), station.n);
    if (station.n == 0) return;
    station.print(name + "_station1");
    ErrorSum all;
    for (const auto& [sensor, e] : sensors) {
        e.print(name + "_station1_" + sensor);
        all.add(e);
    }
    all.print(name + "_station1_sensors");
    // How far each station's sensors disagree about their station's frame: the clouds the
    // segment aligns are this inconsistent, whatever the alignment.
    spread.print(name + "_stations_own_spread");
    std::printf("%s_mean_time %.1f ms\n", name.c_str(), total_ms / station.n);
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
    if (std::string(argv[1]) == "track" && (argc == 6 || argc == 7)) {
        try {
            track_case(argv[2], std::atoll(argv[3]), std::atoll(argv[4]), argv[5],
                       argc == 7 ? std::atof(argv[6]) : 0.0);
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
