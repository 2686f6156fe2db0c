// Pipeline's output thread (poses.csv, extrinsics.yaml, fused clouds, DDS) and the stats
// every thread reports into.
#include <algorithm>

#include "daemon/output_files.hpp"
#include "daemon/pipeline_impl.hpp"

namespace lidarfuse::daemon {

void Pipeline::Impl::output_loop() {
    OutputFiles files(config.output, extrinsics_document(), output_log);
    core::WorldFrame world_now;  // the fusion thread's, once fixed (before its first frame)
    std::int64_t next_diagnostics_ns = steady_ns();
    while (true) {
        auto result = results.pop_wait(std::chrono::milliseconds(100));
        if (reopen.exchange(false)) files.reopen();
        publish_diagnostics_when_due(&next_diagnostics_ns);
        if (!result) {
            if (results.closed()) break;
            continue;
        }
        // The poses and the cloud are in the fused frame (the fusion thread applied the
        // world frame): T_root_sensor holds T_fused_sensor.
        take_world_frame(&world_now);
        files.set_world(world_now, config.output.dds.frame_id, config.world.frame_id);
        publish_frame(*result, world_now);
        files.add_frame(*result, world_now.T_fused_root.inverse());
        spare_clouds.give(std::move(result->cloud));  // for the fusion thread's next frame
    }
    files.write_extrinsics();
    // The final counters, so a subscriber sees how the run ended.
    if (dds) dds->publish_diagnostics(collect_stats(), diagnostics_stamp_ns());
}

// T_root_sensor per sensor (the root frame, as `lidarfuse calibrate` writes it), and the
// world frame that takes it to the published one (extrinsics_yaml.hpp), once known.
io::ExtrinsicsDocument Pipeline::Impl::extrinsics_document() const {
    io::ExtrinsicsDocument extrinsics;
    extrinsics.station = config.station.station;
    extrinsics.root = sensors[config.fusion.root_sensor]->name;
    extrinsics.sensors.resize(sensors.size());
    for (std::size_t s = 0; s < sensors.size(); ++s) extrinsics.sensors[s].name = sensors[s]->name;
    return extrinsics;
}

void Pipeline::Impl::take_world_frame(core::WorldFrame* world_now) const {
    if (world_now->fixed) return;
    std::lock_guard<std::mutex> lock(stats_mutex);
    *world_now = world_frame;
}

void Pipeline::Impl::publish_diagnostics_when_due(std::int64_t* next_diagnostics_ns) {
    if (!dds || steady_ns() < *next_diagnostics_ns) return;
    const auto period_ns = static_cast<std::int64_t>(config.output.dds.diagnostics_period_ms * 1e6);
    *next_diagnostics_ns = steady_ns() + period_ns;
    dds->publish_diagnostics(collect_stats(), diagnostics_stamp_ns());
}

void Pipeline::Impl::publish_frame(const core::FrameOutput& out, const core::WorldFrame& world) {
    const FrameTime times = frame_time(out);
    if (dds) {
        const FrameStamps stamps = frame_stamps_of(out, times);
        dds->publish_frame(out, stamps);
        // geo: <world> -> fused frame on rt/tf_static, with the first stamped frame.
        if (world.kind == core::WorldFrameKind::kGeo)
            dds->publish_static(world.T_world_fused, stamps.frame_ns);
    }
    note_published(out, times);
}

FrameStamps Pipeline::Impl::frame_stamps_of(const core::FrameOutput& out,
                                            const FrameTime& times) const {
    std::vector<std::int64_t> host_ns(sensors.size(), 0);
    if (config.output.stamp == StampSource::kHost) {
        for (std::size_t s = 0; s < sensors.size() && s < out.t_ns.size(); ++s) {
            const bool known = s < times.realtime_ns.size() && times.realtime_ns[s] > 0;
            host_ns[s] =
                known ? times.realtime_ns[s] : out.t_ns[s] - sensors[s]->clock_offset_ns.load();
        }
    }
    return frame_stamps(out, config.output.stamp, host_ns);
}

std::int64_t Pipeline::Impl::diagnostics_stamp_ns() const {
    const std::int64_t now = realtime_ns();
    if (config.output.stamp == StampSource::kHost) return now;
    const auto& root = *sensors[config.fusion.root_sensor];
    if (root.last_scan_steady_ns.load() > 0) return now + root.clock_offset_ns.load();
    for (const auto& s : sensors) {
        if (s->last_scan_steady_ns.load() > 0) return now + s->clock_offset_ns.load();
    }
    return now;
}

// Output thread, after a frame went to DDS: its latency and the members' offsets to the root.
void Pipeline::Impl::note_published(const core::FrameOutput& out, const FrameTime& times) {
    const std::int64_t last_scan = times.last_scan_steady_ns;
    const double latency_ms =
        last_scan > 0 ? static_cast<double>(steady_ns() - last_scan) * 1e-6 : 0.0;
    const std::size_t root = config.fusion.root_sensor;
    std::lock_guard<std::mutex> lock(stats_mutex);
    if (last_scan > 0) last_latency_ms = latency_ms;
    if (root >= out.health.size() || !out.health[root].included) return;
    for (std::size_t s = 0; s < out.health.size() && s < offset_to_root_ms.size(); ++s) {
        if (out.health[s].included)
            offset_to_root_ms[s] = static_cast<double>(out.t_ns[s] - out.t_ns[root]) * 1e-6;
    }
}

PipelineStats Pipeline::Impl::collect_stats() const {
    PipelineStats out;
    const std::int64_t now = steady_ns();
    add_receiver_stats(&out);
    out.frame_queue_drops = frames.dropped();
    out.result_queue_drops = results.dropped();
    std::lock_guard<std::mutex> lock(stats_mutex);
    add_fusion_stats(&out);
    if (recorder) out.record = recorder->stats();
    if (foxglove) out.foxglove = foxglove->stats();
    if (dds) {
        const auto c = dds->counters();
        out.dds_samples_written = c.written;
        out.dds_write_failures = c.failures;
        out.dds_write_timeouts = c.timeouts;
    }
    for (std::size_t i = 0; i < sensors.size(); ++i) out.sensors.push_back(sensor_stats(i, now));
    return out;
}

void Pipeline::Impl::add_receiver_stats(PipelineStats* out) const {
    for (const auto& r : receivers) {
        const auto& st = r->socket->stats();
        out->datagrams += st.datagrams.load();
        out->kernel_drops += st.kernel_drops.load();
        out->truncated += st.truncated.load();
        out->unassigned_datagrams += r->unassigned.load();
        out->scan_queue_drops += r->queue.dropped();
        out->granted_receive_buffers.push_back(r->socket->sockets().front().granted_rcvbuf_bytes);
    }
    for (const auto& d : dds_inputs) out->scan_queue_drops += d->queue().dropped();
}

void Pipeline::Impl::add_fusion_stats(PipelineStats* out) const {
    out->frames_synchronised = sync_counters.frames_complete + sync_counters.frames_partial;
    out->frames_partial = sync_counters.frames_partial;
    out->scans_late = sync_counters.late_dropped;
    out->frames_fused = frames_fused;
    out->frames_predicted = frames_predicted;
    out->last_fusion_ms = last_fusion_ms;
    out->mean_fusion_ms = frames_fused ? sum_fusion_ms / static_cast<double>(frames_fused) : 0.0;
    out->last_latency_ms = last_latency_ms;
    out->world_frame = core::to_string(world_frame.kind);
    out->world_fixed = world_frame.fixed;
    out->frames_before_world_frame = frames_before_world_frame;
    out->last_initial_registration_ms = last_initial_registration_ms;
    out->world_residual_rms_m = world_frame.residual_rms_m;
    out->world_residual_max_m = world_frame.residual_max_m;
}

namespace {

// The ingest's counters (the assembler's copy and the scan counts), mode and metadata state.
void copy_counters(const SensorIngest& s, SensorStats* out) {
    {
        std::lock_guard<std::mutex> counters_lock(s.counters_mutex);
        const auto& c = s.counters;
        for (const auto& counter : kSensorCounters) {
            if (counter.from) out->*counter.member = c.*counter.from;
        }
        out->bad_packets = c.bad_size + c.bad_profile;
        out->mode_seen = s.mode_seen;
        out->metadata = s.metadata_status;
    }
    out->scans_mode_rejected = s.scans_mode_rejected.load();
    out->scans_off_clock = s.scans_off_clock.load();
    out->clock_skew_ms = static_cast<double>(s.clock_skew_ns.load()) * 1e-6;
    out->scans = s.scans.load();
    out->scans_incomplete = s.scans_incomplete.load();
    out->scans_rejected = s.scans_rejected.load();
}

// `last_scan_steady_ns`: 0 when the sensor never completed a scan.
SensorState state_of(const SensorIngest& s, bool enabled, const HealthConfig& health,
                     std::int64_t last_scan_steady_ns, double ms_since_last_scan) {
    if (!enabled) return SensorState::kDisabled;
    if (!s.metadata_known.load()) return SensorState::kNoMetadata;
    if (s.mode_mismatch.load()) return SensorState::kModeMismatch;
    if (last_scan_steady_ns == 0 || ms_since_last_scan > health.lost_after_ms)
        return SensorState::kLost;
    if (ms_since_last_scan > health.stale_after_ms) return SensorState::kStale;
    // A sensor that sends, but on a clock its scans cannot be synchronised by.
    if (s.clock_skewed.load()) return SensorState::kClockSkew;
    return SensorState::kOk;
}

}  // namespace

SensorStats Pipeline::Impl::sensor_stats(std::size_t i, std::int64_t now) const {
    const auto& s = *sensors[i];
    SensorStats ss;
    ss.name = s.name;
    copy_counters(s, &ss);
    ss.last_completeness = s.last_completeness.load();
    const std::int64_t last = s.last_scan_steady_ns.load();
    // `now` was read before the loop: a scan completed since then is 0 ms old, not a
    // negative age (which would read as the "never" sentinel, -1).
    ss.ms_since_last_scan = last > 0 ? std::max(0.0, static_cast<double>(now - last) * 1e-6) : -1.0;
    ss.clock_offset_ms = static_cast<double>(s.clock_offset_ns.load()) * 1e-6;
    ss.offset_to_root_ms = offset_to_root_ms[i];
    ss.state =
        state_of(s, config.station.sensors[i].enabled, config.health, last, ss.ms_since_last_scan);
    ss.pose_valid = last_health[i].pose_valid;
    ss.track_state = core::to_string(last_health[i].state);
    ss.fitness = last_health[i].fitness_reference;
    for (const auto& d : dds_inputs) {
        if (d->sensor_index() == i) ss.dds = d->status();
    }
    return ss;
}

}  // namespace lidarfuse::daemon
