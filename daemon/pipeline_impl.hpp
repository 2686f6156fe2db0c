#pragma once
// Pipeline's state shared by its threads (daemon/pipeline.hpp), one file per concern:
// pipeline.cpp builds it and starts and stops the threads; pipeline_fusion.cpp holds the
// sync and fusion threads' loops (scans in, fused frames out); pipeline_output.cpp the
// output thread's loop (files, DDS) and the stats every thread reports into.

#include <spdlog/spdlog.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/pipeline/frame_synchroniser.hpp"
#include "core/pipeline/fusion_engine.hpp"
#include "core/pipeline/world_frame.hpp"
#include "daemon/buffer_pool.hpp"
#include "daemon/clock_check.hpp"
#include "daemon/dds_input.hpp"
#include "daemon/dds_publisher.hpp"
#include "daemon/doorbell.hpp"
#include "daemon/frame_stamps.hpp"
#include "daemon/metadata_fetcher.hpp"
#include "daemon/pipeline.hpp"
#include "daemon/sensor_ingest.hpp"
#include "drivers/io/extrinsics_yaml.hpp"

namespace lidarfuse::daemon {

struct Pipeline::Impl {
    DaemonConfig config;
    std::vector<std::unique_ptr<SensorIngest>> sensors;
    // Rung by every push into the receivers' and DDS sources' scan queues: the sync thread
    // sleeps on it (declared before the queues' owners, which point to it).
    Doorbell scans_ready;
    std::vector<std::unique_ptr<Receiver>> receivers;
    std::vector<std::unique_ptr<DdsInput>> dds_inputs;  // sensors with source.dds
    DropOldestQueue<core::SyncedFrame<ScanMessage>> frames;
    DropOldestQueue<core::FrameOutput> results;
    // Fused clouds the output thread is done with, for the fusion thread's next frame (one:
    // the output thread is done with a frame before the next is fused, when keeping up).
    BufferPool<core::FusedCloud> spare_clouds{1};
    std::unique_ptr<core::FusionEngine> engine;
    std::unique_ptr<core::WorldFrameTracker> world;  // fusion thread only
    std::thread sync_thread, fusion_thread, output_thread;
    std::atomic<bool> stopping{false};
    std::atomic<std::int64_t> heartbeat_ns{0};
    std::atomic<bool> reopen{false};
    std::shared_ptr<spdlog::logger> ingest_log, sync_log, fusion_log, output_log;

    // Declared before `dds`, which mirrors into it: destroyed after it.
    std::unique_ptr<FoxgloveServer> foxglove;  // null when output.foxglove.enabled is false
    std::unique_ptr<DdsPublisher> dds;         // null when output.dds.enabled is false
    std::unique_ptr<Recorder> recorder;        // null when output.record.enabled is false
    std::vector<std::unique_ptr<MetadataFetcher>> fetchers;  // sensors named by hostname

    // When each synchronised frame's scans completed, for the output thread's latency
    // figure and host stamps: written by the sync thread, looked up by the members'
    // timestamps (the FusionEngine passes them through), a ring of the last kFrameTimes
    // frames.
    struct FrameTime {
        std::vector<std::int64_t> t_ns;         // per sensor, 0 = not included
        std::vector<std::int64_t> realtime_ns;  // per sensor: CLOCK_REALTIME at its last packet
        std::int64_t last_scan_steady_ns = 0;
    };
    static constexpr std::size_t kFrameTimes = 64;
    std::mutex frame_times_mutex;
    std::vector<FrameTime> frame_times{kFrameTimes};
    std::size_t frame_times_next = 0;

    mutable std::mutex stats_mutex;  // guards the fields below (written by sync/fusion/output)
    core::SyncCounters sync_counters;
    std::uint64_t frames_fused = 0;
    std::uint64_t frames_predicted = 0;  // of those, fused at predicted poses
    double last_fusion_ms = 0, sum_fusion_ms = 0;
    std::vector<core::SensorHealth> last_health;
    double last_latency_ms = 0;
    std::vector<double> offset_to_root_ms;
    // A copy of the world frame for the output thread and the stats, written by the fusion
    // thread when it becomes fixed (before the first frame in it is queued).
    core::WorldFrame world_frame;
    std::uint64_t frames_before_world_frame = 0;
    double last_initial_registration_ms = 0;  // wall clock of the last job run

    explicit Impl(const DaemonConfig& c);
    static std::shared_ptr<spdlog::logger> logger(const std::string& name);

    // pipeline.cpp: the constructor's steps, in this order.
    using PortMembers = std::map<std::uint16_t, std::vector<SensorIngest*>>;
    PortMembers make_sensors();
    void make_recorder();
    void make_fetchers();
    void make_receivers(const PortMembers& by_port);
    void make_fusion();
    void make_publishers();
    void make_dds_inputs();

    // pipeline_fusion.cpp
    std::int64_t max_offset_ns() const;
    void sync_loop();
    // Sync thread: whether `scan`'s clock disagrees with the root's (ClockCheck), counted,
    // reported and its buffers handed back to its producer when it does.
    bool refused_off_clock(ClockCheck* check, ScanMessage* scan);
    void record_frame_time(const core::SyncedFrame<ScanMessage>& frame);
    // The frame's entry of the ring; empty t_ns when it is no longer known.
    FrameTime frame_time(const core::FrameOutput& out);
    void fusion_loop();
    // Fusion thread, after process(): the frame's scan buffers back to their sensors.
    void return_scans(core::FrameInput* input);
    // The fusion thread's worker: runs each initial registration job until `jobs` closes.
    using InitialJobs = DropOldestQueue<std::shared_ptr<core::InitialRegistrationJob>>;
    void initial_registration_loop(InitialJobs* jobs);
    // The sensors' track events of a fused frame (problems as warnings).
    void log_sensor_events(const core::FrameOutput& out);
    // The fused frame's figures into the stats (and the world frame, once it became fixed).
    void note_fused(const core::FrameOutput& out, bool world_fixed_now);
    void log_world_frame(const core::WorldFrame& frame);

    // pipeline_output.cpp
    void output_loop();
    io::ExtrinsicsDocument extrinsics_document() const;
    // Output thread: the fusion thread's world frame, until it is fixed.
    void take_world_frame(core::WorldFrame* world_now) const;
    // Output thread: the diagnostics every output.dds.diagnostics_period_ms.
    void publish_diagnostics_when_due(std::int64_t* next_diagnostics_ns);
    // Output thread: a fused frame to DDS (geo: with the world frame's static transform).
    void publish_frame(const core::FrameOutput& out, const core::WorldFrame& world);
    // Output thread, after a frame went to DDS: its latency and the members' offsets to the root.
    void note_published(const core::FrameOutput& out, const FrameTime& times);
    // The stamps of a fused frame's messages in output.stamp's clock (host: the scans'
    // receive times, estimated from the sensor's clock offset when no longer known).
    FrameStamps frame_stamps_of(const core::FrameOutput& out, const FrameTime& times) const;
    // "Now" in output.stamp's clock, for diagnostics: CLOCK_REALTIME, plus (sensor) the
    // root's clock offset, or the first sensor's with a scan when the root has none yet.
    std::int64_t diagnostics_stamp_ns() const;
    PipelineStats collect_stats() const;
    void add_receiver_stats(PipelineStats* out) const;
    void add_fusion_stats(PipelineStats* out) const;                  // stats_mutex held
    SensorStats sensor_stats(std::size_t i, std::int64_t now) const;  // stats_mutex held
};

}  // namespace lidarfuse::daemon
