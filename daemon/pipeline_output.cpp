// Pipeline's output thread (poses.csv, extrinsics.yaml, fused clouds, DDS) and the stats
// every thread reports into.
#include <algorithm>
#include <filesystem>
#include <fstream>

#include "daemon/pipeline_impl.hpp"
#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/fused_cloud_file.hpp"
#include "drivers/io/pose_csv.hpp"

namespace lidarfuse::daemon {

void Pipeline::Impl::output_loop() {
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
    // T_root_sensor per sensor (the root frame, as `lidarfuse calibrate` writes it), and the
    // world frame that takes it to the published one (extrinsics_yaml.hpp).
    io::ExtrinsicsDocument extrinsics;
    extrinsics.station = config.station.station;
    extrinsics.root = sensors[config.fusion.root_sensor]->name;
    extrinsics.sensors.resize(sensors.size());
    for (std::size_t s = 0; s < sensors.size(); ++s) extrinsics.sensors[s].name = sensors[s]->name;
    core::WorldFrame world_now;  // the fusion thread's, once fixed (before its first frame)
    const auto write_extrinsics = [&] {
        if (!out_cfg.extrinsics_yaml) return;
        try {
            io::write_extrinsics_yaml(out_cfg.directory / "extrinsics.yaml", extrinsics);
        } catch (const std::exception& error) {
            output_log->error("{}", error.what());
        }
    };
    const auto note_world = [&] {
        if (!world_now.fixed) {
            std::lock_guard<std::mutex> lock(stats_mutex);
            world_now = world_frame;
        }
        if (!world_now.fixed || extrinsics.world) return;
        extrinsics.world =
            io::extrinsics_world(world_now, config.output.dds.frame_id, config.world.frame_id);
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
            dds->publish_diagnostics(collect_stats(), diagnostics_stamp_ns());
        }
        if (!result) {
            if (results.closed()) break;
            continue;
        }
        // The poses and the cloud are in the fused frame (the fusion thread applied the
        // world frame): T_root_sensor below holds T_fused_sensor.
        note_world();
        const Eigen::Isometry3d T_root_fused = world_now.T_fused_root.inverse();
        const FrameTime times = frame_time(*result);
        if (dds) {
            const FrameStamps stamps = frame_stamps_of(*result, times);
            dds->publish_frame(*result, stamps);
            // geo: <world> -> fused frame on rt/tf_static, with the first stamped frame.
            if (world_now.kind == core::WorldFrameKind::kGeo)
                dds->publish_static(world_now.T_world_fused, stamps.frame_ns);
        }
        note_published(*result, times);
        for (std::size_t s = 0; s < sensors.size(); ++s) {
            const auto& h = result->health[s];
            if (!h.pose_valid) continue;
            auto& e = extrinsics.sensors[s];
            e.registered = true;
            e.T_root_sensor = T_root_fused * result->T_root_sensor[s];
            e.quality["fitness_reference"] = h.fitness_reference;
            if (poses && h.included) {
                io::write_pose_csv_row(poses, {result->frame_index, sensors[s]->name,
                                               result->t_ns[s], result->T_root_sensor[s]});
            }
        }
        if (poses) poses.flush();
        ++frames_seen;
        if (frames_seen == 1 || frames_seen % out_cfg.extrinsics_interval_frames == 0)
            write_extrinsics();
        if (out_cfg.record_clouds_every > 0 &&
            result->frame_index % out_cfg.record_clouds_every == 0) {
            try {
                const bool pcd = out_cfg.record_clouds_format == OutputConfig::CloudFormat::kPcd;
                const auto file =
                    out_cfg.directory /
                    ("fused_" + std::to_string(result->frame_index) + (pcd ? ".pcd" : ".ply"));
                if (pcd) {
                    io::write_fused_cloud_pcd(file, result->cloud);
                } else {
                    io::write_fused_cloud_ply(file, result->cloud);
                }
            } catch (const std::exception& error) {
                output_log->error("{}", error.what());
            }
        }
    }
    write_extrinsics();
    // The final counters, so a subscriber sees how the run ended.
    if (dds) dds->publish_diagnostics(collect_stats(), diagnostics_stamp_ns());
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
    out.mean_fusion_ms =
        m.frames_fused ? m.sum_fusion_ms / static_cast<double>(m.frames_fused) : 0.0;
    out.last_latency_ms = m.last_latency_ms;
    out.world_frame = core::to_string(m.world_frame.kind);
    out.world_fixed = m.world_frame.fixed;
    out.frames_before_world_frame = m.frames_before_world_frame;
    out.last_initial_registration_ms = m.last_initial_registration_ms;
    out.world_residual_rms_m = m.world_frame.residual_rms_m;
    out.world_residual_max_m = m.world_frame.residual_max_m;
    if (m.recorder) out.record = m.recorder->stats();
    if (m.foxglove) out.foxglove = m.foxglove->stats();
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
            for (const auto& counter : kSensorCounters) {
                if (counter.from) ss.*counter.member = c.*counter.from;
            }
            ss.bad_packets = c.bad_size + c.bad_profile;
            ss.mode_seen = s.mode_seen;
            ss.metadata = s.metadata_status;
        }
        ss.scans_mode_rejected = s.scans_mode_rejected.load();
        ss.scans = s.scans.load();
        ss.scans_incomplete = s.scans_incomplete.load();
        ss.scans_rejected = s.scans_rejected.load();
        ss.last_completeness = s.last_completeness.load();
        const std::int64_t last = s.last_scan_steady_ns.load();
        // `now` was read before the loop: a scan completed since then is 0 ms old, not a
        // negative age (which would read as the "never" sentinel, -1).
        ss.ms_since_last_scan =
            last > 0 ? std::max(0.0, static_cast<double>(now - last) * 1e-6) : -1.0;
        ss.clock_offset_ms = static_cast<double>(s.clock_offset_ns.load()) * 1e-6;
        ss.offset_to_root_ms = m.offset_to_root_ms[i];
        if (!m.config.station.sensors[i].enabled) {
            ss.state = SensorState::kDisabled;
        } else if (!s.metadata_known.load()) {
            ss.state = SensorState::kNoMetadata;
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
