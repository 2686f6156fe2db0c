#include "daemon/pipeline.hpp"

#include <pthread.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include "core/pipeline/frame_synchroniser.hpp"
#include "core/pipeline/fusion_engine.hpp"
#include "daemon/dds_publisher.hpp"
#include "daemon/sensor_ingest.hpp"
#include "drivers/io/cloud_ply.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/pose_csv.hpp"

namespace lidarfuse::daemon {

const char* to_string(SensorState state) {
    switch (state) {
        case SensorState::kOk: return "OK";
        case SensorState::kStale: return "STALE";
        case SensorState::kLost: return "LOST";
        case SensorState::kDisabled: return "DISABLED";
        case SensorState::kModeMismatch: return "MODE_MISMATCH";
    }
    return "?";
}

using Clock = std::chrono::steady_clock;

namespace {

// A receiver that waits for CPU behind registration loses packets for good once its socket
// buffer fills; a fusion thread that waits only delivers a frame later. So the compute
// threads (fusion, output) run this much nicer than the process, and so do the threads they
// start (the initial-registration worker, their OpenMP teams): Linux keeps a nice value per
// thread and a new thread inherits its creator's. Raising one needs no privilege.
constexpr int kComputeNiceOffset = 5;

void lower_this_thread_priority(const char* name) {
    const id_t tid = static_cast<id_t>(::gettid());
    errno = 0;
    const int now = ::getpriority(PRIO_PROCESS, tid);
    if (errno != 0 ||
        ::setpriority(PRIO_PROCESS, tid, std::min(now + kComputeNiceOffset, 19)) != 0) {
        spdlog::warn("{}: cannot lower its priority: {}", name, std::strerror(errno));
    }
}

}  // namespace

struct Pipeline::Impl {
    DaemonConfig config;
    std::vector<std::unique_ptr<SensorIngest>> sensors;
    std::vector<std::unique_ptr<Receiver>> receivers;
    DropOldestQueue<core::SyncedFrame<ScanMessage>> frames;
    DropOldestQueue<core::FrameOutput> results;
    std::unique_ptr<core::FusionEngine> engine;
    std::thread sync_thread, fusion_thread, output_thread;
    std::atomic<bool> stopping{false};
    std::atomic<std::int64_t> heartbeat_ns{0};
    std::atomic<bool> reopen{false};
    std::shared_ptr<spdlog::logger> ingest_log, sync_log, fusion_log, output_log;

    std::unique_ptr<DdsPublisher> dds;  // null when output.dds.enabled is false

    // When each synchronised frame's last scan completed, for the output thread's latency
    // figure: written by the sync thread, looked up by the members' timestamps (the
    // FusionEngine passes them through), a ring of the last kFrameTimes frames.
    struct FrameTime {
        std::vector<std::int64_t> t_ns;  // per sensor, 0 = not included
        std::int64_t last_scan_steady_ns = 0;
    };
    static constexpr std::size_t kFrameTimes = 64;
    std::mutex frame_times_mutex;
    std::vector<FrameTime> frame_times{kFrameTimes};
    std::size_t frame_times_next = 0;

    mutable std::mutex stats_mutex;  // guards the fields below (written by sync/fusion/output)
    core::SyncCounters sync_counters;
    std::uint64_t frames_fused = 0;
    double last_fusion_ms = 0, sum_fusion_ms = 0;
    std::vector<core::SensorHealth> last_health;
    double last_latency_ms = 0;
    std::vector<double> offset_to_root_ms;

    explicit Impl(const DaemonConfig& c)
        : config(c),
          frames(static_cast<std::size_t>(c.sync.queue_depth)),
          results(static_cast<std::size_t>(c.sync.queue_depth)) {
        ingest_log = logger("ingest");
        sync_log = logger("sync");
        fusion_log = logger("fusion");
        output_log = logger("output");
        std::map<std::uint16_t, std::vector<SensorIngest*>> by_port;
        std::vector<std::string> problems;
        for (std::size_t i = 0; i < config.station.sensors.size(); ++i) {
            const auto& sc = config.station.sensors[i];
            auto s = std::make_unique<SensorIngest>();
            s->index = i;
            s->name = sc.name;
            s->time_offset_ns = sc.time_offset_ns;
            if (sc.enabled) {
                try {
                    s->info = ouster::load_metadata(sc.metadata);
                    s->info.udp_port_lidar = sc.udp_port;
                    s->lut = ouster::make_xyz_lut(s->info);
                    by_port[sc.udp_port].push_back(s.get());
                } catch (const std::exception& error) {
                    problems.push_back("sensor \"" + sc.name + "\": " + error.what());
                }
            }
            sensors.push_back(std::move(s));
        }
        if (!problems.empty()) {
            std::string text = "cannot start: sensor metadata";
            for (const auto& p : problems) text += "\n  " + p;
            throw std::runtime_error(text);
        }
        for (auto& [port, members] : by_port) {
            receivers.push_back(make_receiver(port, members, config.network, config.station,
                                              config.health.min_completeness));
            receivers.back()->log = ingest_log;
        }
        engine = std::make_unique<core::FusionEngine>(sensors.size(), config.fusion);
        last_health.assign(sensors.size(), core::SensorHealth{});
        offset_to_root_ms.assign(sensors.size(), 0.0);
        if (config.output.dds.enabled) {
            StationFrames names;
            names.station = config.station.station;
            names.fused_frame = config.output.dds.frame_id;
            for (const auto& sc : config.station.sensors) names.sensor_names.push_back(sc.name);
            names.root = config.fusion.root_sensor;
            dds = std::make_unique<DdsPublisher>(config.output.dds, names);
        }
        heartbeat_ns = steady_ns();
    }

    static std::shared_ptr<spdlog::logger> logger(const std::string& name) {
        auto existing = spdlog::get(name);
        if (existing) return existing;
        auto l = spdlog::default_logger()->clone(name);
        spdlog::register_logger(l);
        return l;
    }

    void sync_loop() {
        const auto& root_info = sensors[config.fusion.root_sensor]->info;
        core::SyncParams params;
        const int rate = std::max(1, root_info.frames_per_second);
        params.max_offset_ns = config.sync.max_offset_ms > 0
                                   ? static_cast<std::int64_t>(config.sync.max_offset_ms * 1e6)
                                   : 1'000'000'000LL / rate;
        params.deadline_ns = static_cast<std::int64_t>(config.sync.deadline_ms * 1e6);
        params.reset_jump_ns = static_cast<std::int64_t>(config.sync.reset_jump_ms * 1e6);
        core::FrameSynchroniser<ScanMessage> sync(sensors.size(), params);
        while (!stopping.load(std::memory_order_acquire)) {
            bool any = false;
            for (auto& r : receivers) {
                while (auto m = r->queue.try_pop()) {
                    any = true;
                    const std::size_t sensor = m->sensor;
                    const std::int64_t t = m->t_ns;
                    sync.push(sensor, t, steady_ns(), std::move(*m));
                }
            }
            while (auto frame = sync.poll(steady_ns())) {
                record_frame_time(*frame);
                frames.push(std::move(*frame));
            }
            {
                std::lock_guard<std::mutex> lock(stats_mutex);
                sync_counters = sync.counters();
            }
            if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        frames.close();
    }

    void record_frame_time(const core::SyncedFrame<ScanMessage>& frame) {
        std::lock_guard<std::mutex> lock(frame_times_mutex);
        FrameTime& ft = frame_times[frame_times_next++ % kFrameTimes];
        ft.t_ns.assign(sensors.size(), 0);
        ft.last_scan_steady_ns = 0;
        for (std::size_t s = 0; s < frame.members.size() && s < sensors.size(); ++s) {
            if (!frame.members[s]) continue;
            ft.t_ns[s] = frame.members[s]->t_ns;
            ft.last_scan_steady_ns = std::max(ft.last_scan_steady_ns, frame.members[s]->complete_steady_ns);
        }
    }

    // The steady time the frame's last scan completed, or 0 when it is no longer known.
    std::int64_t frame_time(const core::FrameOutput& out) {
        std::lock_guard<std::mutex> lock(frame_times_mutex);
        for (const auto& ft : frame_times) {
            bool match = !ft.t_ns.empty();
            bool any = false;
            for (std::size_t s = 0; match && s < out.health.size() && s < ft.t_ns.size(); ++s) {
                if (!out.health[s].included) continue;
                any = true;
                match = ft.t_ns[s] == out.t_ns[s];
            }
            if (match && any) return ft.last_scan_steady_ns;
        }
        return 0;
    }

    void fusion_loop() {
        // The initial registration (~1 s) runs on one worker thread that this function starts
        // and joins before it returns, so stop() joining the fusion thread joins it too: the
        // engine hands a job out (FrameOutput::initial_job), this thread passes it on and
        // keeps fusing the sensors already tracked; a later process() applies the result.
        // One job at a time (the engine's rule), so the queue of two never drops one.
        DropOldestQueue<std::shared_ptr<core::InitialRegistrationJob>> init_jobs(2);
        std::thread init_worker([this, &init_jobs] {
            ::pthread_setname_np(::pthread_self(), "lf-init");
            while (true) {
                auto job = init_jobs.pop_wait(std::chrono::milliseconds(100));
                if (job) {
                    (*job)->run();
                    fusion_log->info("initial registration done in {:.0f} ms{}", (*job)->run_ms(),
                                     (*job)->error().empty() ? "" : ": " + (*job)->error());
                } else if (init_jobs.closed()) {
                    break;
                }
            }
        });
        std::shared_ptr<core::InitialRegistrationJob> last_job;
        while (!stopping.load(std::memory_order_acquire)) {
            heartbeat_ns.store(steady_ns(), std::memory_order_release);
            auto frame = frames.pop_wait(std::chrono::milliseconds(100));
            if (!frame) continue;
            core::FrameInput input;
            input.sensors.resize(sensors.size());
            for (std::size_t s = 0; s < sensors.size(); ++s) {
                if (!frame->members[s]) continue;
                auto& in = input.sensors[s];
                in.present = true;
                in.t_ns = frame->members[s]->t_ns;
                in.points = std::move(frame->members[s]->points);
                in.point_dt_s = std::move(frame->members[s]->point_dt_s);
                in.intensity = std::move(frame->members[s]->intensity);
            }
            auto out = engine->process(input);
            if (out.initial_job) {
                last_job = std::move(out.initial_job);
                init_jobs.push(last_job);
            }
            for (std::size_t s = 0; s < sensors.size(); ++s) {
                if (!out.health[s].event.empty()) {
                    fusion_log->warn("frame {}: {}: {}", out.frame_index, sensors[s]->name, out.health[s].event);
                }
            }
            {
                std::lock_guard<std::mutex> lock(stats_mutex);
                ++frames_fused;
                last_fusion_ms = out.timings.total_ms;
                sum_fusion_ms += out.timings.total_ms;
                last_health = out.health;
            }
            results.push(std::move(out));
        }
        // Shutdown: a job not begun is skipped; one running stops at register_initial's next
        // check (between sensors' features or pairs), the longest stop() can wait here.
        if (last_job) last_job->cancel();
        init_jobs.close();
        init_worker.join();
        results.close();
    }

    void output_loop() {
        const auto& out_cfg = config.output;
        std::error_code ec;
        std::filesystem::create_directories(out_cfg.directory, ec);
        if (ec) output_log->error("cannot create {}: {}", out_cfg.directory.string(), ec.message());
        std::ofstream poses;
        const auto open_poses = [&] {
            if (!out_cfg.poses_csv) return;
            poses.close();
            const auto file = out_cfg.directory / "poses.csv";
            const bool fresh = !std::filesystem::exists(file) || std::filesystem::file_size(file) == 0;
            poses.open(file, std::ios::app);
            if (!poses) output_log->error("cannot open {} for appending", file.string());
            if (fresh) io::write_pose_csv_header(poses);
        };
        open_poses();
        std::vector<io::ExtrinsicsEntry> extrinsics(sensors.size());
        for (std::size_t s = 0; s < sensors.size(); ++s) extrinsics[s].name = sensors[s]->name;
        const auto write_extrinsics = [&] {
            if (!out_cfg.extrinsics_yaml) return;
            try {
                io::write_extrinsics_yaml(out_cfg.directory / "extrinsics.yaml",
                                          sensors[config.fusion.root_sensor]->name, extrinsics);
            } catch (const std::exception& error) {
                output_log->error("{}", error.what());
            }
        };
        std::int64_t frames_seen = 0;
        const auto diagnostics_period_ns =
            static_cast<std::int64_t>(config.output.dds.diagnostics_period_ms * 1e6);
        std::int64_t next_diagnostics_ns = steady_ns();
        while (true) {
            auto result = results.pop_wait(std::chrono::milliseconds(100));
            if (reopen.exchange(false)) {
                open_poses();
                write_extrinsics();
                output_log->info("reopened poses.csv and rewrote extrinsics.yaml");
            }
            if (dds && steady_ns() >= next_diagnostics_ns) {
                next_diagnostics_ns = steady_ns() + diagnostics_period_ns;
                dds->publish_diagnostics(collect_stats(), realtime_ns());
            }
            if (!result) {
                if (results.closed()) break;
                continue;
            }
            if (dds) dds->publish_frame(*result);
            note_published(*result);
            for (std::size_t s = 0; s < sensors.size(); ++s) {
                const auto& h = result->health[s];
                if (!h.pose_valid) continue;
                extrinsics[s].registered = true;
                extrinsics[s].T_root_sensor = result->T_root_sensor[s];
                extrinsics[s].quality["fitness_reference"] = h.fitness_reference;
                if (poses && h.included) {
                    io::write_pose_csv_row(poses, {result->frame_index, sensors[s]->name, result->t_ns[s],
                                                   result->T_root_sensor[s]});
                }
            }
            if (poses) poses.flush();
            ++frames_seen;
            if (frames_seen == 1 || frames_seen % out_cfg.extrinsics_interval_frames == 0) write_extrinsics();
            if (out_cfg.record_clouds_every > 0 && result->frame_index % out_cfg.record_clouds_every == 0) {
                try {
                    io::write_fused_cloud_ply(
                        out_cfg.directory / ("fused_" + std::to_string(result->frame_index) + ".ply"),
                        result->cloud);
                } catch (const std::exception& error) {
                    output_log->error("{}", error.what());
                }
            }
        }
        write_extrinsics();
        // The final counters, so a subscriber sees how the run ended.
        if (dds) dds->publish_diagnostics(collect_stats(), realtime_ns());
    }

    // Output thread, after a frame went to DDS: its latency and the members' offsets to the root.
    void note_published(const core::FrameOutput& out) {
        const std::int64_t last_scan = frame_time(out);
        const double latency_ms = last_scan > 0 ? static_cast<double>(steady_ns() - last_scan) * 1e-6 : 0.0;
        const std::size_t root = config.fusion.root_sensor;
        std::lock_guard<std::mutex> lock(stats_mutex);
        if (last_scan > 0) last_latency_ms = latency_ms;
        if (root >= out.health.size() || !out.health[root].included) return;
        for (std::size_t s = 0; s < out.health.size() && s < offset_to_root_ms.size(); ++s) {
            if (out.health[s].included) offset_to_root_ms[s] = static_cast<double>(out.t_ns[s] - out.t_ns[root]) * 1e-6;
        }
    }

    PipelineStats collect_stats() const;
};

Pipeline::Pipeline(const DaemonConfig& config) : impl_(std::make_unique<Impl>(config)) {}

Pipeline::~Pipeline() { stop(); }

// Thread names (at most 15 characters) let `top -H` and the daemon bench tell the stages
// apart: lf-recv-<port>, lf-sync, lf-fusion (and its lf-init worker), lf-output.
void Pipeline::start() {
    Impl& m = *impl_;
    for (auto& r : m.receivers) {
        const std::string name = "lf-recv-" + std::to_string(r->socket->sockets().front().port);
        r->thread = std::thread([&m, rp = r.get(), name] {
            ::pthread_setname_np(::pthread_self(), name.c_str());
            run_receiver(rp);
        });
    }
    m.sync_thread = std::thread([&m] {
        ::pthread_setname_np(::pthread_self(), "lf-sync");
        m.sync_loop();
    });
    m.fusion_thread = std::thread([&m] {
        ::pthread_setname_np(::pthread_self(), "lf-fusion");
        lower_this_thread_priority("lf-fusion");
        m.fusion_loop();
    });
    m.output_thread = std::thread([&m] {
        ::pthread_setname_np(::pthread_self(), "lf-output");
        lower_this_thread_priority("lf-output");
        m.output_loop();
    });
}

void Pipeline::stop() {
    Impl& m = *impl_;
    if (m.stopping.exchange(true)) {
        // Already stopping: still join whatever runs (the destructor after stop()).
    }
    for (auto& r : m.receivers) r->socket->stop();
    for (auto& r : m.receivers) {
        if (r->thread.joinable()) r->thread.join();
        for (auto* s : r->sensors) publish_counters(s);
    }
    if (m.sync_thread.joinable()) m.sync_thread.join();
    m.frames.close();
    if (m.fusion_thread.joinable()) m.fusion_thread.join();
    m.results.close();
    if (m.output_thread.joinable()) m.output_thread.join();
}

std::chrono::steady_clock::time_point Pipeline::heartbeat() const {
    return Clock::time_point(std::chrono::nanoseconds(impl_->heartbeat_ns.load(std::memory_order_acquire)));
}

void Pipeline::request_reopen() { impl_->reopen.store(true); }

int Pipeline::dds_domain_id() const { return impl_->dds ? impl_->dds->domain_id() : -1; }

std::vector<std::uint16_t> Pipeline::bound_ports() const {
    std::vector<std::uint16_t> ports;
    for (const auto& r : impl_->receivers) ports.push_back(r->socket->sockets().front().port);
    return ports;
}

PipelineStats Pipeline::stats() const { return impl_->collect_stats(); }

PipelineStats Pipeline::Impl::collect_stats() const {
    const Impl& m = *this;
    PipelineStats out;
    const std::int64_t now = steady_ns();
    for (const auto& r : m.receivers) {
        const auto& st = r->socket->stats();
        out.datagrams += st.datagrams.load();
        out.kernel_drops += st.kernel_drops.load();
        out.truncated += st.truncated.load();
        out.unassigned_datagrams += r->unassigned.load();
        out.scan_queue_drops += r->queue.dropped();
        out.granted_receive_buffers.push_back(r->socket->sockets().front().granted_rcvbuf_bytes);
    }
    out.frame_queue_drops = m.frames.dropped();
    out.result_queue_drops = m.results.dropped();
    std::lock_guard<std::mutex> lock(m.stats_mutex);
    out.frames_synchronised = m.sync_counters.frames_complete + m.sync_counters.frames_partial;
    out.frames_partial = m.sync_counters.frames_partial;
    out.scans_late = m.sync_counters.late_dropped;
    out.frames_fused = m.frames_fused;
    out.last_fusion_ms = m.last_fusion_ms;
    out.mean_fusion_ms = m.frames_fused ? m.sum_fusion_ms / static_cast<double>(m.frames_fused) : 0.0;
    out.last_latency_ms = m.last_latency_ms;
    if (m.dds) {
        const auto c = m.dds->counters();
        out.dds_samples_written = c.written;
        out.dds_write_failures = c.failures;
        out.dds_write_timeouts = c.timeouts;
    }
    for (std::size_t i = 0; i < m.sensors.size(); ++i) {
        const auto& s = *m.sensors[i];
        SensorStats ss;
        ss.name = s.name;
        {
            std::lock_guard<std::mutex> counters_lock(s.counters_mutex);
            const auto& c = s.counters;
            ss.packets = c.packets;
            ss.lidar_packets = c.lidar_packets;
            ss.imu_packets = c.imu_packets;
            ss.bad_packets = c.bad_size + c.bad_profile;
            ss.late_packets = c.late_packets;
            ss.duplicate_packets = c.duplicate_packets;
            ss.crc_errors = c.crc_errors;
            ss.resets = c.resets;
            ss.mode_mismatch_frames = c.mode_mismatch_frames;
            ss.mode_mismatches = c.mode_mismatches;
            ss.mode_seen = s.mode_seen;
        }
        ss.scans_mode_rejected = s.scans_mode_rejected.load();
        ss.scans = s.scans.load();
        ss.scans_incomplete = s.scans_incomplete.load();
        ss.scans_rejected = s.scans_rejected.load();
        ss.last_completeness = s.last_completeness.load();
        const std::int64_t last = s.last_scan_steady_ns.load();
        ss.ms_since_last_scan = last > 0 ? static_cast<double>(now - last) * 1e-6 : -1.0;
        ss.clock_offset_ms = static_cast<double>(s.clock_offset_ns.load()) * 1e-6;
        ss.offset_to_root_ms = m.offset_to_root_ms[i];
        if (!m.config.station.sensors[i].enabled) {
            ss.state = SensorState::kDisabled;
        } else if (s.mode_mismatch.load()) {
            ss.state = SensorState::kModeMismatch;
        } else if (last == 0 || ss.ms_since_last_scan > m.config.health.lost_after_ms) {
            ss.state = SensorState::kLost;
        } else if (ss.ms_since_last_scan > m.config.health.stale_after_ms) {
            ss.state = SensorState::kStale;
        } else {
            ss.state = SensorState::kOk;
        }
        ss.pose_valid = m.last_health[i].pose_valid;
        ss.track_state = core::to_string(m.last_health[i].state);
        ss.fitness = m.last_health[i].fitness_reference;
        out.sensors.push_back(std::move(ss));
    }
    return out;
}

}  // namespace lidarfuse::daemon
