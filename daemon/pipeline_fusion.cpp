// Pipeline's sync thread (scans from the receivers into synchronised frames) and fusion
// thread (frames through the FusionEngine, the initial registration on a worker).
#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <optional>

#include "core/pipeline/frame_input.hpp"
#include "daemon/log_throttle.hpp"
#include "daemon/pipeline_impl.hpp"
#include "daemon/status_line.hpp"

namespace lidarfuse::daemon {

namespace {

// When the sync thread, with nothing in its queues, looks again unless a scan arrives first
// (every queue rings scans_ready): an open frame's deadline (monotonic ns), and at the
// latest 100 ms from now, to follow a change of the root's frame rate.
std::chrono::steady_clock::time_point next_sync_wake(std::optional<std::int64_t> deadline_ns) {
    constexpr std::int64_t kIdleWakeNs = 100'000'000;
    std::int64_t wake = steady_ns() + kIdleWakeNs;
    if (deadline_ns) wake = std::min(wake, *deadline_ns);
    return std::chrono::steady_clock::time_point(std::chrono::nanoseconds(wake));
}

}  // namespace

// sync.max_offset_ms, or one frame period of the root: its metadata's rate, 10 Hz (the
// widest of Ouster's common modes) while a root named by hostname has none yet.
std::int64_t Pipeline::Impl::max_offset_ns() const {
    if (config.sync.max_offset_ms > 0)
        return static_cast<std::int64_t>(config.sync.max_offset_ms * 1e6);
    const int rate = sensors[config.fusion.root_sensor]->frames_per_second.load();
    return 1'000'000'000LL / (rate > 0 ? rate : 10);
}

void Pipeline::Impl::sync_loop() {
    core::SyncParams params;
    params.max_offset_ns = max_offset_ns();
    params.deadline_ns = static_cast<std::int64_t>(config.sync.deadline_ms * 1e6);
    params.reset_jump_ns = static_cast<std::int64_t>(config.sync.reset_jump_ms * 1e6);
    core::FrameSynchroniser<ScanMessage> sync(sensors.size(), params);
    ClockCheck clocks(sensors.size(), config.fusion.root_sensor,
                      static_cast<std::int64_t>(config.sync.max_clock_skew_ms * 1e6));
    while (!stopping.load(std::memory_order_acquire)) {
        if (const std::int64_t offset = max_offset_ns(); offset != sync.max_offset_ns()) {
            sync.set_max_offset_ns(offset);
            sync_log->info("frames synchronised within {:.1f} ms (the root's frame period)",
                           static_cast<double>(sync.max_offset_ns()) * 1e-6);
        }
        bool any = false;
        const auto take = [&](DropOldestQueue<ScanMessage>& queue) {
            while (auto m = queue.try_pop()) {
                any = true;
                if (refused_off_clock(&clocks, &*m)) continue;
                const std::size_t sensor = m->sensor;
                const std::int64_t t = m->t_ns;
                sync.push(sensor, t, steady_ns(), std::move(*m));
            }
        };
        for (auto& r : receivers) take(r->queue);
        for (auto& d : dds_inputs) take(d->queue());
        while (auto frame = sync.poll(steady_ns())) {
            record_frame_time(*frame);
            frames.push(std::move(*frame));
        }
        {
            std::lock_guard<std::mutex> lock(stats_mutex);
            sync_counters = sync.counters();
        }
        if (!any) scans_ready.wait_until(next_sync_wake(sync.next_deadline_ns()));
    }
    frames.close();
}

bool Pipeline::Impl::refused_off_clock(ClockCheck* check, ScanMessage* scan) {
    SensorIngest& s = *sensors[scan->sensor];
    const auto skew_ns = check->refuse(scan->sensor, scan->t_ns, scan->complete_steady_ns);
    s.clock_skewed.store(skew_ns.has_value());
    if (!skew_ns) return false;
    s.clock_skew_ns.store(*skew_ns);
    const std::uint64_t refused = s.scans_off_clock.fetch_add(1) + 1;
    if (logged_occurrence(refused)) {
        sync_log->warn(
            "sensor \"{}\": {} (more than sync.max_clock_skew_ms, {:.0f} ms): {} scan(s) not "
            "fused; check its time synchronisation (PTP)",
            s.name, clock_skew_reason(static_cast<double>(*skew_ns) * 1e-6),
            config.sync.max_clock_skew_ms, refused);
    }
    s.spare_scans.give(std::move(*scan));
    return true;
}

void Pipeline::Impl::record_frame_time(const core::SyncedFrame<ScanMessage>& frame) {
    std::lock_guard<std::mutex> lock(frame_times_mutex);
    FrameTime& ft = frame_times[frame_times_next++ % kFrameTimes];
    ft.t_ns.assign(sensors.size(), 0);
    ft.realtime_ns.assign(sensors.size(), 0);
    ft.last_scan_steady_ns = 0;
    for (std::size_t s = 0; s < frame.members.size() && s < sensors.size(); ++s) {
        if (!frame.members[s]) continue;
        ft.t_ns[s] = frame.members[s]->t_ns;
        ft.realtime_ns[s] = frame.members[s]->complete_realtime_ns;
        ft.last_scan_steady_ns =
            std::max(ft.last_scan_steady_ns, frame.members[s]->complete_steady_ns);
    }
}

Pipeline::Impl::FrameTime Pipeline::Impl::frame_time(const core::FrameOutput& out) {
    std::lock_guard<std::mutex> lock(frame_times_mutex);
    for (const auto& ft : frame_times) {
        bool match = !ft.t_ns.empty();
        bool any = false;
        for (std::size_t s = 0; match && s < out.health.size() && s < ft.t_ns.size(); ++s) {
            if (!out.health[s].included) continue;
            any = true;
            match = ft.t_ns[s] == out.t_ns[s];
        }
        if (match && any) return ft;
    }
    return {};
}

void Pipeline::Impl::fusion_loop() {
    // The initial registration (~1 s) runs on one worker thread that this function starts
    // and joins before it returns, so stop() joining the fusion thread joins it too: the
    // engine hands a job out (FrameOutput::initial_job), this thread passes it on and
    // keeps fusing the sensors already tracked; a later process() applies the result.
    // One job at a time (the engine's rule), so the queue of two never drops one.
    InitialJobs init_jobs(2);
    std::thread init_worker(&Impl::initial_registration_loop, this, &init_jobs);
    std::shared_ptr<core::InitialRegistrationJob> last_job;
    core::FrameMode mode = core::FrameMode::kRegister;
    while (!stopping.load(std::memory_order_acquire)) {
        heartbeat_ns.store(steady_ns(), std::memory_order_release);
        auto frame = frames.pop_wait(std::chrono::milliseconds(100));
        if (!frame) continue;
        core::FrameInput input = core::frame_input(&*frame, sensors.size());
        if (auto cloud = spare_clouds.take()) engine->recycle(std::move(*cloud));
        auto out = engine->process(input, mode);
        return_scans(&input);
        // Behind (a frame already waits): the next one at its predicted poses, which costs a
        // fraction of a registered one, rather than a frame dropped (sync.when_behind).
        const bool behind = !frames.empty();
        mode = config.sync.predict_when_behind && out.registered && behind
                   ? core::FrameMode::kPredict
                   : core::FrameMode::kRegister;
        if (out.initial_job) {
            last_job = std::move(out.initial_job);
            init_jobs.push(last_job);
        }
        log_sensor_events(out);
        const bool world_fixed_now = world->update(out);
        if (world_fixed_now) log_world_frame(world->frame());
        note_fused(out, world_fixed_now);
        // Until the world frame is known (road: the initial registration), a frame's poses
        // and cloud are in no frame a consumer could keep: counted, not published.
        if (!world->fixed()) continue;
        world->apply(&out);  // poses and cloud into the fused frame (a few ms per 100k points)
        results.push(std::move(out));
    }
    // Shutdown: a job not begun is skipped; one running stops at register_initial's next
    // check (between sensors' features or pairs), the longest stop() can wait here.
    if (last_job) last_job->cancel();
    init_jobs.close();
    init_worker.join();
    results.close();
}

// The engine copied what it keeps of the scans: their buffers go back to the sensors'
// producers, which fill them with the next scans.
void Pipeline::Impl::return_scans(core::FrameInput* input) {
    for (std::size_t s = 0; s < input->sensors.size() && s < sensors.size(); ++s) {
        core::SensorScanInput& scan = input->sensors[s];
        if (!scan.present) continue;
        ScanMessage spare;
        spare.points = std::move(scan.points);
        spare.point_dt_s = std::move(scan.point_dt_s);
        spare.intensity = std::move(scan.intensity);
        sensors[s]->spare_scans.give(std::move(spare));
    }
}

void Pipeline::Impl::initial_registration_loop(InitialJobs* jobs) {
    ::pthread_setname_np(::pthread_self(), "lf-init");
    while (true) {
        auto job = jobs->pop_wait(std::chrono::milliseconds(100));
        if (job) {
            (*job)->run();
            {
                std::lock_guard<std::mutex> lock(stats_mutex);
                last_initial_registration_ms = (*job)->run_ms();
            }
            const std::string& error = (*job)->error();
            fusion_log->log(error.empty() ? spdlog::level::info : spdlog::level::warn,
                            "initial registration done in {:.0f} ms{}, tracks started in {:.0f} ms",
                            (*job)->run_ms(), error.empty() ? "" : ": " + error,
                            (*job)->follow_up_ms());
        } else if (jobs->closed()) {
            break;
        }
    }
}

void Pipeline::Impl::log_sensor_events(const core::FrameOutput& out) {
    for (std::size_t s = 0; s < sensors.size(); ++s) {
        const auto& h = out.health[s];
        if (h.event.empty()) continue;
        fusion_log->log(h.event_is_problem ? spdlog::level::warn : spdlog::level::info,
                        "frame {}: {}: {}", out.frame_index, sensors[s]->name, h.event);
    }
}

void Pipeline::Impl::note_fused(const core::FrameOutput& out, bool world_fixed_now) {
    std::lock_guard<std::mutex> lock(stats_mutex);
    ++frames_fused;
    if (!out.registered) ++frames_predicted;
    last_fusion_ms = out.timings.total_ms;
    sum_fusion_ms += out.timings.total_ms;
    last_health = out.health;
    if (world_fixed_now) world_frame = world->frame();
    if (!world->fixed()) ++frames_before_world_frame;
}

void Pipeline::Impl::log_world_frame(const core::WorldFrame& f) {
    const Eigen::Vector3d t = f.T_fused_root.translation();
    fusion_log->info(
        "world frame ({}) fixed at frame {}: {}; T_fused_root translation [{:.3f}, {:.3f}, {:.3f}] "
        "m",
        core::to_string(f.kind), f.frame_index, f.note, t.x(), t.y(), t.z());
    if (f.kind == core::WorldFrameKind::kRoad && f.num_sensors > 0) {
        fusion_log->info("road plane: root sensor {:.3f} m above it, rms {:.4f} m over {} points",
                         f.root_height_m, f.residual_rms_m, f.num_road_points);
    } else if (f.kind == core::WorldFrameKind::kRoad) {
        fusion_log->warn("world frame: {}", f.note);
    }
    if (f.kind == core::WorldFrameKind::kGeo) {
        const Eigen::Vector3d o = f.T_world_fused.translation();
        fusion_log->info(
            "geo: offset (world -> fused) [{:.3f}, {:.3f}, {:.3f}] m; fit residual rms {:.4f} m, "
            "max {:.4f} m over {} sensors",
            o.x(), o.y(), o.z(), f.residual_rms_m, f.residual_max_m, f.num_sensors);
    }
}

}  // namespace lidarfuse::daemon
