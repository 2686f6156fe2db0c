// `lidarfuse fuse CAPTURE.pcap --config station.yaml --out DIR [...]`: runs the FusionEngine
// over a whole capture as fast as it can; writes poses.csv, timing.csv and chosen clouds.
#include <cstdio>
#include <ctime>
#include <fstream>
#include <limits>
#include <set>

#include "core/common/point_cloud.hpp"
#include "core/pipeline/frame_input.hpp"
#include "core/pipeline/frame_synchroniser.hpp"
#include "core/pipeline/fusion_engine.hpp"
#include "core/pipeline/world_frame.hpp"
#include "drivers/capture/station_capture.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/fused_cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/station/fusion_config.hpp"
#include "drivers/station/world_config.hpp"
#include "tools/args.hpp"
#include "tools/command.hpp"
#include "tools/progress.hpp"

namespace lidarfuse::tools {

namespace {

struct PendingScan {
    std::int64_t t_ns = 0;
    std::vector<Eigen::Vector3f> points;  // as core::SensorScanInput's
    std::vector<float> point_dt_s;
    std::vector<float> intensity;
};

// CPU time of the whole process (every thread), ms: unlike wall-clock time, it does not grow
// when other jobs share the cores.
double process_cpu_ms() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

const char* const kUsage =
    "usage: lidarfuse fuse CAPTURE.pcap|RECORDING --config station.yaml --out DIR\n"
    "                      [--voxel-size M] [--window K] [--threads N] [--save-cloud FRAME ...]\n"
    "                      [--max-frames N]\n"
    "                      [--no-deskew] [--no-dynamic] [--reference-voxel M]\n"
    "                      [--reference-target-voxel M] [--sensor-grid] [--world road|sensor|geo]\n"
    "                      [--quiet]\n"
    "Decodes the capture (a pcap file, or a recording folder of lidarfused: its files in\n"
    "order) with the production ingest, groups one scan per sensor into frames,\n"
    "and runs the FusionEngine on every frame. Writes DIR/poses.csv (T_fused_sensor per sensor\n"
    "and frame, in the config's world frame, world.frame, as lidarfused publishes it; header\n"
    "frame,sensor,t_ns,x,y,z,qw,qx,qy,qz), DIR/extrinsics.yaml (the last frame's poses and the\n"
    "world frame), DIR/timing.csv (ms per stage per frame) and DIR/fused_<FRAME>.ply (fused\n"
    "frame) for each --save-cloud frame. --world overrides world.frame (geo needs the config's\n"
    "world.positions or world.T_world_root). On a terminal, a progress line on stderr (frames,\n"
    "share of the file, rate, time left); --quiet: none.\n"
    "Parameters: the config's registration and dynamics sections, as lidarfused reads them\n"
    "(config/station.schema.md); the options override them (--threads: default 2).\n"
    "Accuracy knobs (core/pipeline/fusion_types.hpp): --no-deskew: no per-column motion\n"
    "compensation; --reference-voxel: voxel of the one-off\n"
    "fine edges between the reference frames (0: off); --reference-target-voxel: voxel of the\n"
    "reference target (0: --voxel-size); --sensor-grid: voxel grids in each sensor's frame\n"
    "instead of the root frame.\n";

// The config's registration and dynamics sections, as lidarfused reads them; the options
// override them.
core::FusionParams fuse_params(const Args& args, const station::StationConfig& station) {
    core::FusionParams params = station::load_fusion_params(args.required("--config"));
    params.root_sensor = station.root_index();
    params.voxel_size_m = args.number("--voxel-size", params.voxel_size_m);
    params.window_frames = static_cast<int>(args.integer("--window", params.window_frames));
    params.num_threads = static_cast<int>(args.integer("--threads", 2));
    if (args.flag("--no-deskew")) params.deskew = false;
    if (args.flag("--no-dynamic")) params.remove_dynamic = false;
    params.reference_voxel_size_m = args.number("--reference-voxel", params.reference_voxel_size_m);
    params.reference_target_voxel_size_m =
        args.number("--reference-target-voxel", params.reference_target_voxel_size_m);
    if (args.flag("--sensor-grid")) params.voxel_grid_in_root_frame = false;
    params.initial_registration_inline = true;  // offline: deterministic, timing-independent
    if (!(params.voxel_size_m > 0)) throw UsageError("--voxel-size must be positive");
    if (params.window_frames < 2) throw UsageError("--window must be at least 2");
    return params;
}

// The config's world section, its frame kind overridden by --world.
station::WorldConfig fuse_world_config(const Args& args, const station::StationConfig& station,
                                       const core::FusionParams& params) {
    station::WorldConfig world_config =
        station::load_world_config(args.required("--config"), station);
    if (const auto w = args.value("--world")) {
        const auto kind = core::world_frame_kind_from(*w);
        if (!kind) throw UsageError("--world: expected road, sensor or geo, got \"" + *w + "\"");
        if (*kind == core::WorldFrameKind::kGeo && world_config.params.anchors.empty() &&
            !world_config.params.T_world_root) {
            throw UsageError(
                "--world geo needs world.positions or world.T_world_root in the config");
        }
        world_config.params.kind = *kind;
    }
    world_config.params.settle_frames = core::world_frame_settle_frames(params);
    return world_config;
}

std::set<long long> saved_frames(const Args& args) {
    std::set<long long> save;
    for (const auto& f : args.values("--save-cloud")) save.insert(std::stoll(f));
    return save;
}

PendingScan pending_scan(const capture::CaptureScan& scan) {
    PendingScan pending;
    pending.t_ns = scan.t_ns;
    core::cast_points(scan.cloud->cloud.points, &pending.points);
    ouster::point_times_s(*scan.cloud, static_cast<std::uint64_t>(scan.sensor_t_ns),
                          &pending.point_dt_s);
    ouster::point_intensity(*scan.scan, *scan.cloud, &pending.intensity);
    return pending;
}

// Where one fuse run is: the engine, the world frame and the frames waiting for it, the
// outputs and the time counters. Single-threaded: the capture calls on_scan() on this thread.
class FuseRun {
public:
    FuseRun(const Args& args, const station::StationConfig& station,
            const core::FusionParams& params, std::filesystem::path out_dir, long long max_frames,
            std::set<long long> save, capture::StationCapture* capture, ProgressLine* progress)
        : station_(station),
          params_(params),
          out_dir_(std::move(out_dir)),
          max_frames_(max_frames),
          save_(std::move(save)),
          capture_(*capture),
          progress_(*progress),
          n_(station.sensors.size()),
          engine_(n_, params_),
          world_config_(fuse_world_config(args, station, params_)),
          world_(world_config_.params, n_),
          last_poses_(n_),
          // Frames: members within one frame period of each other (1/SR of the root sensor).
          synchroniser_(n_, core::offline_sync_params(
                                capture->infos()[params_.root_sensor].frames_per_second)),
          timing_(out_dir_ / "timing.csv"),
          last_event_(n_),
          file_bytes_(progress_file_bytes(args.positionals()[0])) {
        for (std::size_t s = 0; s < n_; ++s) last_poses_[s].name = station.sensors[s].name;
        timing_ << "frame,t_ns,sensors_included,sensors_tracking,initial_ms,preprocess_ms,"
                   "registration_ms,graph_ms,fuse_ms,total_ms\n";
    }

    // Fuses every frame of the capture (up to --max-frames), then the ones still open.
    void run() {
        // Forwards to a member: all state stays in this object.
        capture_.run([this](const capture::CaptureScan& scan) { return on_scan(scan); });
        while (frames_ < max_frames_) {
            auto frame = synchroniser_.poll(std::numeric_limits<std::int64_t>::max());
            if (!frame) break;
            fuse_frame(std::move(*frame));
        }
        progress_.finish();
    }

    // Writes poses.csv and extrinsics.yaml, prints the summary; the exit code.
    int finish() const {
        if (!waiting_.empty()) {
            std::fprintf(
                stderr,
                "world frame: not known by the end of the capture; %zu frames not written (%s)\n",
                waiting_.size(), world_.frame().note.c_str());
        }
        io::write_pose_csv(out_dir_ / "poses.csv", poses_);
        write_extrinsics();
        print_sensor_counters();
        print_parameters_and_world();
        print_frames_and_times();
        if (!capture_.pcap_warning().empty())
            std::fprintf(stderr, "warning: %s\n", capture_.pcap_warning().c_str());
        return frames_ > 0 ? 0 : 1;
    }

private:
    bool on_scan(const capture::CaptureScan& scan) {
        synchroniser_.push(scan.sensor, scan.t_ns, scan.capture_time_ns, pending_scan(scan));
        while (frames_ < max_frames_) {
            auto frame = synchroniser_.poll(scan.capture_time_ns);
            if (!frame) break;
            fuse_frame(std::move(*frame));
            show_progress();
        }
        return frames_ < max_frames_;
    }

    void fuse_frame(core::SyncedFrame<PendingScan>&& frame) {
        const core::FrameInput input = core::frame_input(&frame, n_);
        const double cpu0_ms = process_cpu_ms();
        auto out = engine_.process(input);
        const double cpu_ms = process_cpu_ms() - cpu0_ms;
        const std::size_t tracking = report_events(out);
        const auto t = out.timings;
        timing_ << out.frame_index << ',' << frame.t_ns << ',' << frame.included() << ','
                << tracking << ',' << t.initial_ms << ',' << t.preprocess_ms << ','
                << t.registration_ms << ',' << t.graph_ms << ',' << t.fuse_ms << ',' << t.total_ms
                << '\n';
        hand_to_world(std::move(out));
        count_time(t.initial_ms, t.total_ms, cpu_ms);
        ++frames_;
    }

    // Prints each sensor's new health event on a line of its own; the sensors tracking.
    std::size_t report_events(const core::FrameOutput& out) {
        std::size_t tracking = 0;
        for (std::size_t s = 0; s < n_; ++s) {
            const auto& h = out.health[s];
            if (!h.event.empty() && h.event != last_event_[s]) {
                progress_.finish();  // the message on a line of its own; redrawn below it
                std::fprintf(stderr, "frame %lld: %s: %s\n", frames_,
                             station_.sensors[s].name.c_str(), h.event.c_str());
            }
            last_event_[s] = h.event;
            tracking += h.pose_valid && h.included;
        }
        return tracking;
    }

    // The world frame: poses and cloud into the fused frame, written once it is known. Frames
    // fused before (road: a few frames, until the root's reference is deskewed) wait in
    // waiting_; offline, nothing needs to be left out.
    void hand_to_world(core::FrameOutput&& out) {
        world_.update(out);
        if (!world_.fixed()) ++frames_before_world_;
        // Only the saved clouds wait; the others' buffers carry the next frame's cloud.
        if (!save_.count(out.frame_index)) engine_.recycle(std::move(out.cloud));
        waiting_.push_back(std::move(out));
        if (world_.fixed()) {
            for (auto& w : waiting_) write_in_world(&w);
            waiting_.clear();
        }
    }

    void write_in_world(core::FrameOutput* out) {
        world_.apply(out);
        for (std::size_t s = 0; s < n_; ++s) {
            const auto& h = out->health[s];
            if (!h.pose_valid || !h.included) continue;
            poses_.push_back(
                {out->frame_index, station_.sensors[s].name, out->t_ns[s], out->T_root_sensor[s]});
            last_poses_[s].registered = true;
            last_poses_[s].T_root_sensor =
                world_.frame().T_fused_root.inverse() * out->T_root_sensor[s];
        }
        if (save_.count(out->frame_index)) {
            io::write_fused_cloud_ply(
                out_dir_ / ("fused_" + std::to_string(out->frame_index) + ".ply"), out->cloud);
        }
    }

    // A frame whose initial registration took most of its time counts as initial, all
    // others as continuous (wall-clock and process CPU ms).
    void count_time(double frame_initial_ms, double frame_total_ms, double cpu_ms) {
        total_ms_ += frame_total_ms;
        if (frame_initial_ms > 0.5 * frame_total_ms) {
            initial_ms_ += frame_total_ms;
        } else {
            continuous_ms_ += frame_total_ms;
            continuous_cpu_ms_ += cpu_ms;
            ++continuous_frames_;
        }
    }

    void show_progress() {
        const double read = static_cast<double>(capture_.pcap_stats().bytes_read);
        progress_.update({"fusing", static_cast<double>(frames_), 0, "frames",
                          file_bytes_ > 0 ? read / file_bytes_ : -1.0, 0});
    }

    void write_extrinsics() const {
        const core::WorldFrame& wf = world_.frame();
        io::ExtrinsicsDocument extrinsics{
            station_.station, station_.root, last_poses_, {}, std::nullopt};
        if (wf.fixed) {
            // As lidarfused writes it, without a fused frame name (fuse has no DDS output).
            extrinsics.world = io::extrinsics_world(wf, "", world_config_.frame_id);
        }
        io::write_extrinsics_yaml(out_dir_ / "extrinsics.yaml", extrinsics);
    }

    void print_sensor_counters() const {
        for (std::size_t s = 0; s < n_; ++s) {
            const auto& c = capture_.counters(s);
            std::printf("fuse_%s_frames_complete %llu frames\n", station_.sensors[s].name.c_str(),
                        static_cast<unsigned long long>(c.frames_complete));
            std::printf("fuse_%s_frames_incomplete %llu frames\n", station_.sensors[s].name.c_str(),
                        static_cast<unsigned long long>(c.frames_incomplete));
        }
    }

    // The parameters this run used (config sections and options combined) and the world frame.
    void print_parameters_and_world() const {
        const core::WorldFrame& wf = world_.frame();
        std::printf("fuse_voxel_size %g m\n", params_.voxel_size_m);
        std::printf("fuse_window %d frames\n", params_.window_frames);
        std::printf("fuse_deskew %d flag\n", params_.deskew ? 1 : 0);
        std::printf("fuse_remove_dynamic %d flag\n", params_.remove_dynamic ? 1 : 0);
        std::printf("fuse_world_frame %s frame\n", core::to_string(wf.kind));
        std::printf("fuse_world_fixed_at %lld frame\n", static_cast<long long>(wf.frame_index));
        std::printf("fuse_world_frames_before %lld frames\n",
                    frames_before_world_);  // written late
        std::printf("fuse_world_frames_unwritten %zu frames\n", waiting_.size());
        if (wf.fixed && wf.kind == core::WorldFrameKind::kRoad) {
            std::printf("fuse_world_road_sensors %zu sensors\n", wf.num_sensors);
            std::printf("fuse_world_root_height %.4f m\n", wf.root_height_m);
            std::printf("fuse_world_road_rms %.4f m\n", wf.residual_rms_m);
            std::printf("fuse_world_road_points %zu points\n", wf.num_road_points);
        }
        if (wf.fixed && wf.kind == core::WorldFrameKind::kGeo) {
            const Eigen::Vector3d o = wf.T_world_fused.translation();
            std::printf("fuse_world_geo_offset %.3f,%.3f,%.3f m\n", o.x(), o.y(), o.z());
            std::printf("fuse_world_geo_residual_rms %.4f m\n", wf.residual_rms_m);
            std::printf("fuse_world_geo_residual_max %.4f m\n", wf.residual_max_m);
            std::printf("fuse_world_geo_frames_averaged %zu frames\n", wf.num_frames);
        }
        if (!wf.note.empty()) std::fprintf(stderr, "world frame: %s\n", wf.note.c_str());
    }

    void print_frames_and_times() const {
        const auto& sc = synchroniser_.counters();
        std::printf("fuse_frames %lld frames\n", frames_);
        std::printf("fuse_frames_partial %llu frames\n",
                    static_cast<unsigned long long>(sc.frames_partial));
        std::printf("fuse_scans_late_dropped %llu scans\n",
                    static_cast<unsigned long long>(sc.late_dropped));
        std::printf("fuse_initial_registration_time %.1f ms\n", initial_ms_);
        std::printf(
            "fuse_continuous_mean_time %.2f ms\n",
            continuous_frames_ ? continuous_ms_ / static_cast<double>(continuous_frames_) : 0.0);
        std::printf("fuse_continuous_mean_cpu_time %.2f ms\n",
                    continuous_frames_
                        ? continuous_cpu_ms_ / static_cast<double>(continuous_frames_)
                        : 0.0);
        std::printf("fuse_total_time %.1f ms\n", total_ms_);
    }

    const station::StationConfig& station_;
    const core::FusionParams params_;
    const std::filesystem::path out_dir_;
    const long long max_frames_;
    const std::set<long long> save_;
    capture::StationCapture& capture_;
    ProgressLine& progress_;
    const std::size_t n_;
    core::FusionEngine engine_;
    const station::WorldConfig world_config_;
    core::WorldFrameTracker world_;
    std::vector<core::FrameOutput> waiting_;
    long long frames_before_world_ = 0;
    std::vector<io::ExtrinsicsEntry> last_poses_;
    core::FrameSynchroniser<PendingScan> synchroniser_;
    std::vector<io::PoseRecord> poses_;
    std::ofstream timing_;
    std::vector<std::string> last_event_;
    const double file_bytes_;  // 0: no share of the file shown
    long long frames_ = 0;
    double total_ms_ = 0, continuous_ms_ = 0, initial_ms_ = 0, continuous_cpu_ms_ = 0;
    long long continuous_frames_ = 0;
};

int run_fuse(int argc, char** argv) {
    const Args args(argc, argv,
                    {"--config", "--out", "--voxel-size", "--window", "--threads", "--save-cloud",
                     "--max-frames", "--reference-voxel", "--reference-target-voxel", "--world"},
                    {"--no-deskew", "--no-dynamic", "--sensor-grid", "--quiet"});
    if (args.help()) {
        std::printf("%s", kUsage);
        return 0;
    }
    if (args.positionals().size() != 1)
        throw UsageError("expected one CAPTURE.pcap or RECORDING folder\n" + std::string(kUsage));
    const auto station = station::load_station_config(args.required("--config"));
    const std::filesystem::path out_dir = args.required("--out");
    std::filesystem::create_directories(out_dir);

    capture::StationCapture capture(station, args.positionals()[0]);
    ProgressLine progress("fuse", progress_wanted(args));
    const core::FusionParams params = fuse_params(args, station);
    const long long max_frames =
        args.integer("--max-frames", std::numeric_limits<long long>::max());
    FuseRun run(args, station, params, out_dir, max_frames, saved_frames(args), &capture,
                &progress);
    run.run();
    return run.finish();
}

}  // namespace

LIDARFUSE_REGISTER_COMMAND("fuse",
                           "run the FusionEngine over a capture: poses.csv, timing.csv, clouds",
                           run_fuse);

}  // namespace lidarfuse::tools
