// `lidarfuse calibrate CAPTURE.pcap --config station.yaml --out extrinsics.yaml [--frame N]`:
// the initial registration (issue 4) on one synchronised frame of a capture. Decodes with
// the production ingest, takes the first complete synchronised frame (or the N-th, 0-based)
// -- one complete scan per enabled sensor, grouped as `fuse` groups them (members within
// 1/SR) -- runs core::register_initial and writes every sensor's T_root_sensor plus the
// per-pair quality figures. Sensors that cannot be registered are written with
// `registered: false` and the reason, never with a pose.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/initial_registration.hpp"
#include "core/pipeline/frame_synchroniser.hpp"
#include "core/se3.hpp"
#include "drivers/capture/station_capture.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/station/fusion_config.hpp"
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

int run_calibrate(int argc, char** argv) {
    const Args args(argc, argv, {"--config", "--out", "--frame", "--threads"}, {});
    if (args.help()) {
        std::printf("%s", kUsage);
        return 0;
    }
    if (args.positionals().size() != 1) throw UsageError("expected one CAPTURE.pcap\n" + std::string(kUsage));
    const auto start = std::chrono::steady_clock::now();
    auto station_config = station::load_station_config(args.required("--config"));
    // The registration section's initial-registration keys, as lidarfused uses them.
    core::InitialRegistrationParams params = station::load_fusion_params(args.required("--config")).initial;
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
    // The frame: the same grouping as `fuse` (core::FrameSynchroniser, members within one
    // frame period of the root's rate, capture time as the clock), over complete scans only;
    // the wanted-th frame that holds every enabled sensor.
    core::FrameSynchroniser<core::PointCloud> synchroniser(
        order.size(), core::offline_sync_params(capture.infos()[root].frames_per_second));
    long long complete_frames = 0;
    std::vector<core::PointCloud> clouds;
    const auto take_ready = [&](std::int64_t now_ns) {
        while (clouds.empty()) {
            auto frame = synchroniser.poll(now_ns);
            if (!frame) return;
            if (frame->included() != order.size() || complete_frames++ != wanted) continue;
            for (auto& member : frame->members) clouds.push_back(std::move(*member));
        }
    };
    capture.run([&](const capture::CaptureScan& scan) {
        if (sensors[scan.sensor].enabled && scan.scan->complete()) {
            synchroniser.push(position[scan.sensor], scan.t_ns, scan.capture_time_ns, scan.cloud->cloud);
            take_ready(scan.capture_time_ns);
        }
        return clouds.empty();
    });
    take_ready(std::numeric_limits<std::int64_t>::max());
    if (clouds.empty()) {
        throw std::runtime_error(args.positionals()[0] + ": no complete synchronised frame #" +
                                 std::to_string(wanted) + " with every sensor of " +
                                 args.required("--config"));
    }
    const double decode_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    params.num_threads = static_cast<int>(args.integer("--threads", 2));
    const core::InitialRegistrationResult result = core::register_initial(clouds, params);

    io::ExtrinsicsDocument doc;
    doc.station = station_config.station;
    doc.root = sensors[root].name;
    std::printf("%-16s %-10s %10s %10s %10s %8s %8s %8s  %s\n", "sensor", "status", "x_m", "y_m", "z_m",
                "roll_deg", "pitch_deg", "yaw_deg", "reason");
    for (std::size_t k = 0; k < order.size(); ++k) {
        const auto& r = result.sensors[k];
        io::ExtrinsicsEntry entry;
        entry.name = sensors[order[k]].name;
        entry.registered = r.registered;
        entry.quality["points"] = static_cast<double>(r.num_input_points);
        entry.quality["keypoints"] = static_cast<double>(r.num_keypoints);
        if (r.registered) {
            entry.T_root_sensor = r.T_root_sensor;
            // Z-Y-X (yaw, pitch, roll) angles for the table, in degrees.
            const Eigen::Matrix3d& R = r.T_root_sensor.linear();
            const Eigen::Vector3d ypr(std::atan2(R(1, 0), R(0, 0)) * 180.0 / M_PI,
                                      std::asin(std::clamp(-R(2, 0), -1.0, 1.0)) * 180.0 / M_PI,
                                      std::atan2(R(2, 1), R(2, 2)) * 180.0 / M_PI);
            std::printf("%-16s %-10s %10.3f %10.3f %10.3f %8.3f %8.3f %8.3f\n", entry.name.c_str(), "ok",
                        r.T_root_sensor.translation().x(), r.T_root_sensor.translation().y(),
                        r.T_root_sensor.translation().z(), ypr.z(), ypr.y(), ypr.x());  // roll, pitch, yaw
        } else {
            entry.reason = core::to_string(r.status);
            std::printf("%-16s %-10s %10s %10s %10s %8s %8s %8s  %s\n", entry.name.c_str(), "FAILED", "-", "-",
                        "-", "-", "-", "-", entry.reason.c_str());
        }
        doc.sensors.push_back(std::move(entry));
    }
    for (const auto& s : sensors) {
        if (s.enabled) continue;
        io::ExtrinsicsEntry entry;
        entry.name = s.name;
        entry.reason = "disabled in the station config";
        doc.sensors.push_back(std::move(entry));
    }
    std::printf("\n%-16s %-16s %-28s %10s %8s %8s %12s %10s\n", "source", "target", "status", "p2p_m",
                "inliers", "overlap", "min_eig_H", "free_viol");
    for (const auto& p : result.pairs) {
        io::ExtrinsicsPair pair;
        pair.source = sensors[order[p.source]].name;
        pair.target = sensors[order[p.target]].name;
        pair.status = core::to_string(p.status);
        pair.figures["p2p_error_m"] = p.p2p_error_m;
        pair.figures["inliers"] = static_cast<double>(p.gicp_inliers);
        pair.figures["p2p_inliers"] = static_cast<double>(p.p2p_inliers);
        pair.figures["overlap_share"] = p.overlap_share;
        pair.figures["min_hessian_eigenvalue"] = p.min_hessian_eigenvalue;
        pair.figures["free_space_violation_share"] = p.free_space_violation_share;
        std::printf("%-16s %-16s %-28s %10.3f %8zu %8.2f %12.4g %10.3f\n", pair.source.c_str(),
                    pair.target.c_str(), pair.status.c_str(), p.p2p_error_m, p.gicp_inliers, p.overlap_share,
                    p.min_hessian_eigenvalue, std::max(p.free_space_violation_share, p.worst_rejected_violation_share));
        doc.pairs.push_back(std::move(pair));
    }
    io::write_extrinsics_yaml(out_path, doc);

    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("\ncalibrate_decode_time %.1f ms\n", 1e3 * decode_s);
    std::printf("calibrate_features_time %.1f ms\n", 1e3 * result.timings.features_s);
    std::printf("calibrate_pairs_time %.1f ms\n", 1e3 * result.timings.pairs_s);
    std::printf("calibrate_polish_time %.1f ms\n", 1e3 * result.timings.polish_s);
    std::printf("calibrate_polished_pairs %zu of %zu pairs\n", result.polish.polished,
                result.polish.polished + result.polish.kept);
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
