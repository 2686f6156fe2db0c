// `lidarfuse calibrate`: the initial registration (issue 4) with no initial guess, from
//   - one synchronised frame of a capture: `CAPTURE.pcap --config station.yaml [--frame N]`,
//     decoded with the production ingest; the first complete synchronised frame (or the N-th,
//     0-based) -- one complete scan per enabled sensor, grouped as `fuse` groups them
//     (members within 1/SR);
//   - or one point-cloud file per sensor, any LiDAR: `--cloud NAME=FILE ...` (PCD or PLY,
//     each cloud in its own sensor frame, metres; drivers/io/cloud_file.hpp), the root being
//     `--root` or the first cloud; `--config` is optional there and only its registration
//     section is read.
// Both run core::register_initial with the same parameters and write every sensor's
// T_root_sensor plus the per-pair quality figures. Sensors that cannot be registered are
// written with `registered: false` and the reason, never with a pose.
// With a capture, the config's `world:` section is followed as lidarfused and `fuse` do:
// extrinsics.yaml gets the same `world:` block and each sensor's T_fused_sensor (road, geo;
// sensor, and --cloud files: the root frame only, as before).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "core/common/se3.hpp"
#include "core/common/stopwatch.hpp"
#include "core/initial/initial_registration.hpp"
#include "core/pipeline/frame_synchroniser.hpp"
#include "core/pipeline/world_frame.hpp"
#include "drivers/capture/station_capture.hpp"
#include "drivers/io/cloud_file.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/station/fusion_config.hpp"
#include "drivers/station/world_config.hpp"
#include "tools/args.hpp"
#include "tools/command.hpp"
#include "tools/progress.hpp"

namespace lidarfuse::tools {

namespace {

const char* const kUsage =
    "usage: lidarfuse calibrate CAPTURE.pcap --config station.yaml --out extrinsics.yaml\n"
    "                           [--frame N] [--threads N] [--quiet]\n"
    "       lidarfuse calibrate --cloud NAME=FILE --cloud NAME=FILE [--cloud NAME=FILE ...]\n"
    "                           [--root NAME] --out extrinsics.yaml [--config station.yaml]\n"
    "                           [--threads N] [--quiet]\n"
    "On a terminal, a progress line on stderr per stage (reading, features, pairs, pose\n"
    "graph); --quiet: none.\n"
    "Finds every sensor's pose relative to the root sensor with no initial guess, from one\n"
    "synchronised frame of a capture (the first complete one, or the N-th complete one\n"
    "counting from 0), or from one point-cloud file per sensor (PCD or PLY, any LiDAR, each\n"
    "in its own sensor frame, metres; the root is --root or the first --cloud). Writes\n"
    "extrinsics.yaml (translation [x, y, z] in metres, rotation_wxyz) with the per-pair\n"
    "quality figures, and prints the same as a table.\n"
    "Exit status: 0 every sensor registered; 2 some refused (the registered ones are still\n"
    "written); 1 an error (bad file, config or option).\n";

// What register_initial runs on: one cloud per sensor, the root first.
struct CalibrationInput {
    std::string station;             // for extrinsics.yaml; empty for cloud files
    std::vector<std::string> names;  // names[k] is the sensor of clouds[k]
    std::vector<core::PointCloud> clouds;
    std::vector<std::string> disabled;          // sensors of the config left out
    std::vector<std::size_t> config_index;      // capture: the config's index of clouds[k]
    std::optional<station::WorldConfig> world;  // capture: the config's `world:` section
};

// The enabled sensors' scans of one synchronised frame of a capture (the N-th complete one).
CalibrationInput input_from_capture(const Args& args) {
    if (args.positionals().size() != 1)
        throw UsageError("expected one CAPTURE.pcap\n" + std::string(kUsage));
    const std::string config_path = args.required("--config");
    const auto station_config = station::load_station_config(config_path);
    const long long wanted = args.integer("--frame", 0);
    if (wanted < 0) throw UsageError("--frame must be >= 0");

    // Registration runs on the enabled sensors (the root first: register_initial's frame
    // is its sensor 0); `order[k]` is the config index of registration sensor k.
    capture::StationCapture capture(station_config, args.positionals()[0]);
    const auto& sensors = station_config.sensors;
    const std::size_t root = station_config.root_index();
    if (!sensors[root].enabled) {
        throw std::runtime_error(config_path + ": root sensor \"" + sensors[root].name +
                                 "\" is disabled");
    }
    CalibrationInput input;
    input.station = station_config.station;
    std::vector<std::size_t> order{root};
    std::vector<std::size_t> position(sensors.size(), 0);
    for (std::size_t s = 0; s < sensors.size(); ++s) {
        if (!sensors[s].enabled) input.disabled.push_back(sensors[s].name);
        if (s != root && sensors[s].enabled) {
            position[s] = order.size();
            order.push_back(s);
        }
    }
    for (std::size_t s : order) input.names.push_back(sensors[s].name);
    input.config_index = order;
    input.world = station::load_world_config(config_path, station_config);
    // The frame: the same grouping as `fuse` (core::FrameSynchroniser, members within one
    // frame period of the root's rate, capture time as the clock), over complete scans only;
    // the wanted-th frame that holds every enabled sensor.
    core::FrameSynchroniser<core::PointCloud> synchroniser(
        order.size(), core::offline_sync_params(capture.infos()[root].frames_per_second));
    long long complete_frames = 0;
    const auto take_ready = [&](std::int64_t now_ns) {
        while (input.clouds.empty()) {
            auto frame = synchroniser.poll(now_ns);
            if (!frame) return;
            if (frame->included() != order.size() || complete_frames++ != wanted) continue;
            for (auto& member : frame->members) input.clouds.push_back(std::move(*member));
        }
    };
    capture.run([&](const capture::CaptureScan& scan) {
        if (sensors[scan.sensor].enabled && scan.scan->complete()) {
            synchroniser.push(position[scan.sensor], scan.t_ns, scan.capture_time_ns,
                              scan.cloud->cloud);
            take_ready(scan.capture_time_ns);
        }
        return input.clouds.empty();
    });
    take_ready(std::numeric_limits<std::int64_t>::max());
    if (input.clouds.empty()) {
        throw std::runtime_error(args.positionals()[0] + ": no complete synchronised frame #" +
                                 std::to_string(wanted) + " with every sensor of " + config_path);
    }
    return input;
}

// One cloud file per `--cloud NAME=FILE`, the root (`--root`, else the first) moved first.
// Every argument is checked before any file is read.
CalibrationInput input_from_cloud_files(const Args& args) {
    if (!args.positionals().empty()) {
        throw UsageError("--cloud and a CAPTURE.pcap cannot be combined\n" + std::string(kUsage));
    }
    if (args.value("--frame"))
        throw UsageError("--frame applies to a capture, not to --cloud files");
    std::vector<std::pair<std::string, std::string>> specs;  // name, file
    for (const std::string& spec : args.values("--cloud")) {
        const auto eq = spec.find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == spec.size()) {
            throw UsageError("--cloud " + spec + ": expected NAME=FILE");
        }
        for (const auto& [name, file] : specs) {
            if (name == spec.substr(0, eq))
                throw UsageError("--cloud " + spec + ": sensor \"" + name + "\" given twice");
        }
        specs.emplace_back(spec.substr(0, eq), spec.substr(eq + 1));
    }
    if (specs.size() < 2)
        throw UsageError("expected at least two --cloud NAME=FILE\n" + std::string(kUsage));
    const std::string root = args.value("--root").value_or(specs.front().first);
    const auto it =
        std::find_if(specs.begin(), specs.end(), [&](const auto& s) { return s.first == root; });
    if (it == specs.end()) throw UsageError("--root " + root + ": no --cloud of that name");
    std::rotate(specs.begin(), it, it + 1);

    CalibrationInput input;
    for (const auto& [name, file] : specs) {
        io::CloudFile cloud = io::read_cloud_file(file);
        std::printf(
            "cloud %-16s %9zu points (%zu without a return or not finite dropped) from %s\n",
            name.c_str(), cloud.cloud.size(), cloud.num_dropped, file.c_str());
        input.names.push_back(name);
        input.clouds.push_back(std::move(cloud.cloud));
    }
    return input;
}

// Z-Y-X (yaw, pitch, roll) angles of a rotation, in degrees.
Eigen::Vector3d yaw_pitch_roll_deg(const Eigen::Matrix3d& R) {
    return Eigen::Vector3d(std::atan2(R(1, 0), R(0, 0)), std::asin(std::clamp(-R(2, 0), -1.0, 1.0)),
                           std::atan2(R(2, 1), R(2, 2))) *
           180.0 / M_PI;
}

// Every sensor's pose (or reason) into the document and the table.
void report_sensors(const CalibrationInput& input, const core::InitialRegistrationResult& result,
                    io::ExtrinsicsDocument* doc) {
    std::printf("%-16s %-10s %10s %10s %10s %8s %8s %8s  %s\n", "sensor", "status", "x_m", "y_m",
                "z_m", "roll_deg", "pitch_deg", "yaw_deg", "reason");
    for (std::size_t k = 0; k < input.names.size(); ++k) {
        const auto& r = result.sensors[k];
        io::ExtrinsicsEntry entry;
        entry.name = input.names[k];
        entry.registered = r.registered;
        entry.quality["points"] = static_cast<double>(r.num_input_points);
        entry.quality["keypoints"] = static_cast<double>(r.num_keypoints);
        if (r.registered) {
            entry.T_root_sensor = r.T_root_sensor;
            const Eigen::Vector3d ypr = yaw_pitch_roll_deg(r.T_root_sensor.linear());
            const Eigen::Vector3d t = r.T_root_sensor.translation();
            std::printf("%-16s %-10s %10.3f %10.3f %10.3f %8.3f %8.3f %8.3f\n", entry.name.c_str(),
                        "ok", t.x(), t.y(), t.z(), ypr.z(), ypr.y(), ypr.x());
        } else {
            entry.reason = core::to_string(r.status);
            std::printf("%-16s %-10s %10s %10s %10s %8s %8s %8s  %s\n", entry.name.c_str(),
                        "FAILED", "-", "-", "-", "-", "-", "-", entry.reason.c_str());
        }
        doc->sensors.push_back(std::move(entry));
    }
    for (const std::string& name : input.disabled) {
        io::ExtrinsicsEntry entry;
        entry.name = name;
        entry.reason = "disabled in the station config";
        doc->sensors.push_back(std::move(entry));
    }
}

// Every pair's figures into the document and the table.
void report_pairs(const CalibrationInput& input, const core::InitialRegistrationResult& result,
                  io::ExtrinsicsDocument* doc) {
    std::printf("\n%-16s %-16s %-28s %10s %8s %8s %12s %10s\n", "source", "target", "status",
                "p2p_m", "inliers", "overlap", "min_eig_H", "free_viol");
    for (const auto& p : result.pairs) {
        io::ExtrinsicsPair pair;
        pair.source = input.names[static_cast<std::size_t>(p.source)];
        pair.target = input.names[static_cast<std::size_t>(p.target)];
        pair.status = core::to_string(p.status);
        pair.figures["p2p_error_m"] = p.chosen.p2p_error_m;
        pair.figures["inliers"] = static_cast<double>(p.chosen.gicp_inliers);
        pair.figures["p2p_inliers"] = static_cast<double>(p.chosen.p2p_inliers);
        pair.figures["overlap_share"] = p.chosen.overlap_share;
        pair.figures["min_hessian_eigenvalue"] = p.chosen.min_hessian_eigenvalue;
        pair.figures["free_space_violation_share"] = p.chosen.free_space_violation_share;
        std::printf(
            "%-16s %-16s %-28s %10.3f %8zu %8.2f %12.4g %10.3f\n", pair.source.c_str(),
            pair.target.c_str(), pair.status.c_str(), p.chosen.p2p_error_m, p.chosen.gicp_inliers,
            p.chosen.overlap_share, p.chosen.min_hessian_eigenvalue,
            std::max(p.chosen.free_space_violation_share, p.worst_rejected_violation_share));
        doc->pairs.push_back(std::move(pair));
    }
}

// The `name value unit` lines: wall time per stage, and the time inside each stage summed
// over sensors / pairs (they run in parallel, so those add up to more than the wall time).
void print_figures(const core::InitialRegistrationResult& result, double input_s, double total_s,
                   std::size_t num_sensors) {
    std::printf("\ncalibrate_decode_time %.1f ms\n", 1e3 * input_s);
    std::printf("calibrate_features_time %.1f ms\n", 1e3 * result.timings.features_s);
    std::printf("calibrate_pairs_time %.1f ms\n", 1e3 * result.timings.pairs_s);
    std::printf("calibrate_polish_time %.1f ms\n", 1e3 * result.timings.polish_s);
    std::printf("calibrate_polished_pairs %zu of %zu pairs\n", result.polish.polished,
                result.polish.polished + result.polish.kept);
    std::printf("calibrate_pose_graph_time %.1f ms\n", 1e3 * result.timings.pose_graph_s);
    const core::StageTimeSums sums = core::sum_stage_timings(result);
    const core::SensorFeatureTimings& f = sums.features;
    const core::PairTimings& pt = sums.pairs;
    const std::pair<const char*, double> stages[] = {{"preprocess", f.preprocess_s},
                                                     {"normals", f.normals_s},
                                                     {"octree", f.octree_s},
                                                     {"sift", f.keypoints_s},
                                                     {"fpfh", f.fpfh_s},
                                                     {"ground_plane", f.ground_s},
                                                     {"gicp_cloud", f.gicp_cloud_s},
                                                     {"matching", pt.matching_s},
                                                     {"ground_search", pt.ground_search_s},
                                                     {"ransac", pt.ransac_s},
                                                     {"gicp", pt.gicp_s},
                                                     {"p2p", pt.p2p_s}};
    for (const auto& [name, seconds] : stages)
        std::printf("calibrate_stage_%s_sum %.1f ms\n", name, 1e3 * seconds);
    std::printf("calibrate_total_time %.1f ms\n", 1e3 * total_s);
    std::printf("calibrate_registered %zu of %zu sensors\n", result.num_registered(), num_sensors);
}

// The world frame of the config's `world:` section from this one registration, as
// core::WorldFrameTracker fixes it in lidarfused and `fuse`, with what calibrate has:
//   road: every registered sensor's road plane from the registration (weighted by inliers),
//     without the tracker's refinement on the fused cloud's static points, which needs a
//     fused frame (and deskewed scans) that calibrate does not make;
//   geo: from the registered anchors' positions of this one frame (the tracker averages
//     them over world.average_frames: a swaying pole's sway is in this residual), or the
//     given T_world_root.
// Nothing (root frame only) for sensor, or when geo has fewer than 3 registered anchors.
std::optional<core::WorldFrame> world_frame(const CalibrationInput& input,
                                            const core::InitialRegistrationResult& result) {
    if (!input.world) return std::nullopt;
    const core::WorldFrameParams& p = input.world->params;
    if (p.kind == core::WorldFrameKind::kRoad) {
        return core::road_frame_or_root_frame(
            core::road_planes_of(result, Eigen::Isometry3d::Identity()),
            Eigen::Isometry3d::Identity(), nullptr, p.road);
    }
    if (p.kind == core::WorldFrameKind::kGeo && p.T_world_root) {
        return core::geo_frame_from(*p.T_world_root, p.offset_step_m);
    }
    if (p.kind == core::WorldFrameKind::kGeo) {
        std::vector<Eigen::Vector3d> in_root, in_world;
        for (const auto& a : p.anchors) {
            for (std::size_t k = 0; k < input.config_index.size(); ++k) {
                if (input.config_index[k] != a.sensor || !result.sensors[k].registered) continue;
                in_root.push_back(result.sensors[k].T_root_sensor.translation());
                in_world.push_back(a.position_m);
            }
        }
        core::WorldFrame f = core::fit_geo_frame(in_root, in_world, p.offset_step_m);
        if (!f.fixed) {
            std::fprintf(stderr, "world frame: %s; extrinsics.yaml in the root frame only\n",
                         f.note.c_str());
            return std::nullopt;
        }
        f.num_frames = 1;
        return f;
    }
    return std::nullopt;
}

void print_world(const core::WorldFrame& f) {
    std::printf("\ncalibrate_world_frame %s frame\n", core::to_string(f.kind));
    if (f.kind == core::WorldFrameKind::kRoad) {
        std::printf("calibrate_world_road_sensors %zu sensors\n", f.num_sensors);
        std::printf("calibrate_world_root_height %.4f m\n", f.root_height_m);
    } else if (f.kind == core::WorldFrameKind::kGeo) {
        const Eigen::Vector3d o = f.T_world_fused.translation();
        std::printf("calibrate_world_geo_offset %.3f,%.3f,%.3f m\n", o.x(), o.y(), o.z());
        std::printf("calibrate_world_geo_residual_rms %.4f m\n", f.residual_rms_m);
        std::printf("calibrate_world_geo_residual_max %.4f m\n", f.residual_max_m);
    }
    if (!f.note.empty()) std::fprintf(stderr, "world frame: %s\n", f.note.c_str());
}

int run_calibrate(int argc, char** argv) {
    const Args args(argc, argv, {"--config", "--out", "--frame", "--threads", "--cloud", "--root"},
                    {"--quiet"});
    if (args.help()) {
        std::printf("%s", kUsage);
        return 0;
    }
    const core::Stopwatch whole;
    const bool from_files = !args.values("--cloud").empty();
    if (!from_files && args.value("--root")) throw UsageError("--root applies to --cloud files");
    const std::string out_path = args.required("--out");
    // The registration section's initial-registration keys, as lidarfused uses them.
    const auto config = args.value("--config");
    core::InitialRegistrationParams params = config ? station::load_fusion_params(*config).initial
                                                    : core::default_initial_registration_params();
    ProgressLine progress("calibrate", progress_wanted(args));
    progress.update({from_files ? "reading the clouds" : "reading the capture", 0, 0, "", -1, 0});
    const CalibrationInput input =
        from_files ? input_from_cloud_files(args) : input_from_capture(args);
    const double input_s = whole.seconds();

    const int threads = static_cast<int>(args.integer("--threads", 2));
    params.on_progress = [&](const char* stage, std::size_t done, std::size_t total) {
        const bool sensors = std::string(stage) == "features";
        progress.update({stage, static_cast<double>(done), static_cast<double>(total),
                         sensors ? "sensors" : (std::string(stage) == "pairs" ? "pairs" : ""),
                         total > 0 ? static_cast<double>(done) / static_cast<double>(total) : -1.0,
                         0});
    };
    const core::InitialRegistrationResult result =
        core::register_initial(input.clouds, params, threads);
    progress.finish();

    io::ExtrinsicsDocument doc;
    doc.station = input.station;
    doc.root = input.names.front();
    report_sensors(input, result, &doc);
    report_pairs(input, result, &doc);
    if (const auto world = world_frame(input, result)) {
        print_world(*world);
        // As lidarfused writes it, without the fused frame's tf name (output.dds.frame_id is
        // the daemon's section, not read here).
        doc.world = io::extrinsics_world(*world, "", input.world->frame_id);
    }
    io::write_extrinsics_yaml(out_path, doc);
    print_figures(result, input_s, whole.seconds(), input.names.size());
    return result.num_registered() == input.names.size() ? 0 : 2;
}

}  // namespace

LIDARFUSE_REGISTER_COMMAND("calibrate",
                           "initial registration: extrinsics of every sensor from one frame",
                           run_calibrate);

}  // namespace lidarfuse::tools
