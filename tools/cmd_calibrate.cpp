// `lidarfuse calibrate CAPTURE.pcap --config station.yaml --out extrinsics.yaml [--frame N]`:
// the initial registration (issue 4) on one synchronised frame of a capture. Decodes with
// the production ingest, takes the first complete synchronised frame (or the N-th, 0-based)
// -- one complete scan per enabled sensor, all within 1/SR of the root's -- runs
// core::register_initial and writes every sensor's T_root_sensor plus the per-pair quality
// figures. Sensors that cannot be registered are written with `registered: false` and the
// reason, never with a pose.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <fstream>
#include <optional>

#include "core/initial_registration.hpp"
#include "core/se3.hpp"
#include "drivers/capture/station_capture.hpp"
#include "tools/args.hpp"
#include "tools/command.hpp"

namespace lidarfuse::tools {

namespace {

const char* kUsage =
    "usage: lidarfuse calibrate CAPTURE.pcap --config station.yaml --out extrinsics.yaml\n"
    "                           [--frame N] [--threads N]\n"
    "Finds every sensor's pose relative to the root sensor from one synchronised frame\n"
    "(the first complete one, or the N-th complete one counting from 0), with no initial\n"
    "guess. Writes extrinsics.yaml (translation [x, y, z] in metres, rotation_wxyz) with the\n"
    "per-pair quality figures, and prints the same as a table.\n";

struct TimedCloud {
    std::int64_t t_ns = 0;
    core::PointCloud cloud;
};

// Picks the `wanted`-th complete frame online: the root's scans in order, each matched
// with the other sensors' scans nearest in time within max_offset_ns.
class FramePicker {
public:
    FramePicker(std::size_t sensors, std::size_t root, std::int64_t max_offset_ns, long long wanted)
        : scans_(sensors), root_(root), max_offset_ns_(max_offset_ns), wanted_(wanted) {}

    // Returns true once the frame is found (then frame() holds it).
    bool push(std::size_t sensor, TimedCloud scan) {
        scans_[sensor].push_back(std::move(scan));
        while (!scans_[root_].empty()) {
            const std::int64_t t = scans_[root_].front().t_ns;
            bool decided = true;
            bool complete = true;
            std::vector<std::size_t> pick(scans_.size(), 0);
            for (std::size_t s = 0; s < scans_.size(); ++s) {
                if (s == root_) continue;
                auto& q = scans_[s];
                // Scans too old for this and every later root scan are dropped.
                while (!q.empty() && q.front().t_ns < t - max_offset_ns_) q.pop_front();
                std::optional<std::size_t> best;
                for (std::size_t k = 0; k < q.size(); ++k) {
                    if (std::llabs(q[k].t_ns - t) < max_offset_ns_ &&
                        (!best || std::llabs(q[k].t_ns - t) < std::llabs(q[*best].t_ns - t))) {
                        best = k;
                    }
                }
                if (best) {
                    pick[s] = *best;
                } else if (!q.empty() && q.back().t_ns >= t + max_offset_ns_) {
                    complete = false;  // this sensor has moved past t without a match
                } else {
                    decided = false;  // still waiting for this sensor
                }
            }
            if (!decided) return false;
            if (complete && found_++ == wanted_) {
                frame_.assign(scans_.size(), {});
                for (std::size_t s = 0; s < scans_.size(); ++s) {
                    frame_[s] = std::move(scans_[s][s == root_ ? 0 : pick[s]].cloud);
                }
                return true;
            }
            scans_[root_].pop_front();
        }
        return false;
    }
    std::vector<core::PointCloud>& frame() { return frame_; }

private:
    std::vector<std::deque<TimedCloud>> scans_;
    std::size_t root_;
    std::int64_t max_offset_ns_;
    long long wanted_;
    long long found_ = 0;
    std::vector<core::PointCloud> frame_;
};

YAML::Node pose_node(const Eigen::Isometry3d& T) {
    const Eigen::Quaterniond q = core::quaternion_of(T);
    YAML::Node node;
    node["translation"] = std::vector<double>{T.translation().x(), T.translation().y(), T.translation().z()};
    node["translation"].SetStyle(YAML::EmitterStyle::Flow);
    node["rotation_wxyz"] = std::vector<double>{q.w(), q.x(), q.y(), q.z()};
    node["rotation_wxyz"].SetStyle(YAML::EmitterStyle::Flow);
    return node;
}

int run_calibrate(int argc, char** argv) {
    const Args args(argc, argv, {"--config", "--out", "--frame", "--threads"}, {});
    if (args.help()) {
        std::printf("%s", kUsage);
        return 0;
    }
    if (args.positionals().size() != 1) throw UsageError("expected one CAPTURE.pcap\n" + std::string(kUsage));
    const auto start = std::chrono::steady_clock::now();
    auto station_config = station::load_station_config(args.required("--config"));
    const std::string out_path = args.required("--out");
    const long long wanted = args.integer("--frame", 0);
    if (wanted < 0) throw UsageError("--frame must be >= 0");

    // Registration runs on the enabled sensors (the root first: register_initial's frame
    // is its sensor 0); `order[k]` is the config index of registration sensor k.
    capture::StationCapture capture(station_config, args.positionals()[0]);
    const auto& sensors = station_config.sensors;
    const std::size_t root = station_config.root_index();
    if (!sensors[root].enabled) {
        throw std::runtime_error(args.required("--config") + ": root sensor \"" + sensors[root].name +
                                 "\" is disabled");
    }
    std::vector<std::size_t> order{root};
    std::vector<std::size_t> position(sensors.size(), 0);
    for (std::size_t s = 0; s < sensors.size(); ++s) {
        if (s != root && sensors[s].enabled) {
            position[s] = order.size();
            order.push_back(s);
        }
    }
    const int rate = std::max(1, capture.infos()[root].frames_per_second);
    FramePicker picker(order.size(), 0, 1'000'000'000LL / rate, wanted);
    bool found = false;
    capture.run([&](const capture::CaptureScan& scan) {
        if (found || !scan.scan->complete()) return !found;
        found = picker.push(position[scan.sensor], TimedCloud{scan.t_ns, scan.cloud->cloud});
        return !found;
    });
    if (!found) {
        throw std::runtime_error(args.positionals()[0] + ": no complete synchronised frame #" +
                                 std::to_string(wanted) + " with every sensor of " +
                                 args.required("--config"));
    }
    const double decode_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    std::vector<core::PointCloud> clouds = std::move(picker.frame());
    core::InitialRegistrationParams params = core::default_initial_registration_params();
    params.num_threads = static_cast<int>(args.integer("--threads", 2));
    const core::InitialRegistrationResult result = core::register_initial(clouds, params);

    YAML::Node doc;
    doc["station"] = station_config.station;
    doc["root"] = sensors[root].name;
    std::printf("%-16s %-10s %10s %10s %10s %8s %8s %8s  %s\n", "sensor", "status", "x_m", "y_m", "z_m",
                "roll_deg", "pitch_deg", "yaw_deg", "reason");
    for (std::size_t k = 0; k < order.size(); ++k) {
        const auto& r = result.sensors[k];
        YAML::Node node;
        node["name"] = sensors[order[k]].name;
        node["registered"] = r.registered;
        if (r.registered) {
            const YAML::Node pose = pose_node(r.T_root_sensor);
            node["T_root_sensor"] = pose;
            // Z-Y-X (yaw, pitch, roll) angles for the table, in degrees.
            const Eigen::Matrix3d& R = r.T_root_sensor.linear();
            const Eigen::Vector3d ypr(std::atan2(R(1, 0), R(0, 0)) * 180.0 / M_PI,
                                      std::asin(std::clamp(-R(2, 0), -1.0, 1.0)) * 180.0 / M_PI,
                                      std::atan2(R(2, 1), R(2, 2)) * 180.0 / M_PI);
            std::printf("%-16s %-10s %10.3f %10.3f %10.3f %8.3f %8.3f %8.3f\n",
                        sensors[order[k]].name.c_str(), "ok", r.T_root_sensor.translation().x(),
                        r.T_root_sensor.translation().y(), r.T_root_sensor.translation().z(), ypr.z(),
                        ypr.y(), ypr.x());  // roll, pitch, yaw
        } else {
            node["reason"] = core::to_string(r.status);
            std::printf("%-16s %-10s %10s %10s %10s %8s %8s %8s  %s\n", sensors[order[k]].name.c_str(),
                        "FAILED", "-", "-", "-", "-", "-", "-", core::to_string(r.status));
        }
        node["points"] = r.num_input_points;
        node["keypoints"] = r.num_keypoints;
        doc["sensors"].push_back(node);
    }
    for (const auto& s : sensors) {
        if (s.enabled) continue;
        YAML::Node node;
        node["name"] = s.name;
        node["registered"] = false;
        node["reason"] = "disabled in the station config";
        doc["sensors"].push_back(node);
    }
    std::printf("\n%-16s %-16s %-28s %10s %8s %8s %12s %10s\n", "source", "target", "status", "p2p_m",
                "inliers", "overlap", "min_eig_H", "free_viol");
    for (const auto& p : result.pairs) {
        YAML::Node node;
        node["source"] = sensors[order[p.source]].name;
        node["target"] = sensors[order[p.target]].name;
        node["status"] = core::to_string(p.status);
        node["p2p_error_m"] = p.p2p_error_m;
        node["inliers"] = p.gicp_inliers;
        node["p2p_inliers"] = p.p2p_inliers;
        node["overlap_share"] = p.overlap_share;
        node["min_hessian_eigenvalue"] = p.min_hessian_eigenvalue;
        node["free_space_violation_share"] = p.free_space_violation_share;
        doc["pairs"].push_back(node);
        std::printf("%-16s %-16s %-28s %10.3f %8zu %8.2f %12.4g %10.3f\n", sensors[order[p.source]].name.c_str(),
                    sensors[order[p.target]].name.c_str(), core::to_string(p.status), p.p2p_error_m,
                    p.gicp_inliers, p.overlap_share, p.min_hessian_eigenvalue,
                    std::max(p.free_space_violation_share, p.worst_rejected_violation_share));
    }
    std::ofstream out(out_path);
    if (!out) throw std::runtime_error(out_path + ": cannot open for writing");
    out << "# lidarfuse calibrate: T_root_sensor maps sensor coordinates into the root sensor's frame\n"
        << doc << '\n';
    if (!out) throw std::runtime_error(out_path + ": write failed");

    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("\ncalibrate_decode_time %.1f ms\n", 1e3 * decode_s);
    std::printf("calibrate_features_time %.1f ms\n", 1e3 * result.timings.features_s);
    std::printf("calibrate_pairs_time %.1f ms\n", 1e3 * result.timings.pairs_s);
    std::printf("calibrate_pose_graph_time %.1f ms\n", 1e3 * result.timings.pose_graph_s);
    // Time inside each stage summed over sensors / pairs (they run in parallel, so these
    // add up to more than the wall-clock stages above).
    const core::StageTimeSums sums = core::sum_stage_timings(result);
    const core::SensorFeatureTimings& f = sums.features;
    const core::PairTimings& pt = sums.pairs;
    const std::pair<const char*, double> stages[] = {
        {"preprocess", f.preprocess_s}, {"normals", f.normals_s},       {"octree", f.octree_s},
        {"sift", f.keypoints_s},        {"fpfh", f.fpfh_s},             {"ground_plane", f.ground_s},
        {"gicp_cloud", f.gicp_cloud_s}, {"matching", pt.matching_s},    {"ground_search", pt.ground_search_s},
        {"ransac", pt.ransac_s},        {"gicp", pt.gicp_s},            {"p2p", pt.p2p_s}};
    for (const auto& [name, seconds] : stages) std::printf("calibrate_stage_%s_sum %.1f ms\n", name, 1e3 * seconds);
    std::printf("calibrate_total_time %.1f ms\n", 1e3 * total_s);
    std::printf("calibrate_registered %zu of %zu sensors\n", result.num_registered(), order.size());
    return result.num_registered() == order.size() ? 0 : 2;
}

}  // namespace

LIDARFUSE_REGISTER_COMMAND("calibrate", "initial registration: extrinsics of every sensor from one frame",
                           run_calibrate);

}  // namespace lidarfuse::tools
