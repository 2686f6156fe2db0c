#pragma once
// lidarfused's thread pipeline (DESIGN.md data flow, one direction, no back edges):
//
//   receiver threads (one per UDP port): recvmmsg -> sensor routing -> packet parsing and
//       scan assembly -> projection -> ScanMessage into that receiver's queue
//   sync thread: scans -> FrameSynchroniser (steady clock deadline) -> frame queue
//   fusion thread: FusionEngine::process -> world frame (core/pipeline/world_frame.hpp: the
//       frame's poses and cloud re-expressed in the fused frame; frames before it is
//       known are counted, not published) -> result queue; beats the heartbeat
//   output thread: poses.csv, extrinsics.yaml, clouds, diagnostics log
//   lf-foxglove (output.foxglove): the live view's WebSocket server; the output thread
//       hands it the DDS samples' bytes (daemon/foxglove_server.hpp), never waits for it
//   recorder thread (output.record): every received datagram, copied by the receivers,
//       into rotating pcap files (daemon/recorder.hpp)
//
// The receiving side is daemon/sensor_ingest; this file wires the stages together.
// Every queue is a DropOldestQueue: a slow stage costs its oldest input, counted, and a
// receiver never waits. The constructor binds every socket (errors list every port) and
// starts nothing; start() starts the threads; stop() wakes every thread and joins them.
// Thread-safe accessors: stats(), heartbeat(), sensor_states().

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/dds_input_status.hpp"
#include "daemon/foxglove_server.hpp"
#include "daemon/metadata_status.hpp"
#include "daemon/recorder.hpp"
#include "drivers/ouster/assembly_counters.hpp"

namespace lidarfuse::daemon {

// kModeMismatch: the sensor sends, but its data disagrees with the metadata's lidar_mode or
// profile (drivers/ouster/mode_check.hpp); its scans are not fused until it agrees again.
// kNoMetadata: a sensor named by hostname whose metadata could not be fetched yet
// (daemon/metadata_fetcher.hpp); its datagrams cannot be read until it is.
// kClockSkew: the sensor's clock disagrees with the root's by more than
// sync.max_clock_skew_ms (daemon/clock_check.hpp); its scans are not fused until it agrees.
enum class SensorState { kOk, kStale, kLost, kDisabled, kModeMismatch, kNoMetadata, kClockSkew };
const char* to_string(SensorState state);

struct SensorStats {
    std::string name;
    SensorState state = SensorState::kLost;
    // Every std::uint64_t counter here has its row in kSensorCounters (below).
    std::uint64_t packets = 0, lidar_packets = 0, bad_packets = 0, late_packets = 0,
                  duplicate_packets = 0, crc_errors = 0, resets = 0;
    std::uint64_t scans = 0, scans_incomplete = 0,
                  scans_rejected = 0;  // rejected: below min completeness
    // Mode check: frames that disagreed with the metadata, times the sensor was flagged,
    // scans not fused for it, and the last disagreement seen vs what the metadata says.
    std::uint64_t mode_mismatch_frames = 0, mode_mismatches = 0, scans_mode_rejected = 0;
    std::string mode_seen;
    // Scans refused for a clock that disagrees with the root's, and the latest refused
    // scan's clock minus the root's (ms; positive: ahead).
    std::uint64_t scans_off_clock = 0;
    double clock_skew_ms = 0.0;
    double last_completeness = 0.0;
    double ms_since_last_scan = -1.0;
    // Sensor clock minus host clock (CLOCK_REALTIME) when its last scan completed (large
    // when replaying an old capture or when the sensor is not time-synchronised), and its
    // last fused scan's time minus the root's in the same frame.
    double clock_offset_ms = 0.0, offset_to_root_ms = 0.0;
    MetadataStatus metadata;
    std::optional<DdsInputStatus> dds;  // a sensor whose clouds come from DDS (source.dds)
    bool pose_valid = false;
    std::string track_state;
    double fitness = 0.0;
};

// A counter of SensorStats: its diagnostics key, the member, its unit, and the assembler's
// counter it copies (nullptr: counted by the ingest, or bad_packets, the sum of bad_size and
// bad_profile).
struct SensorCounter {
    const char* name;
    std::uint64_t SensorStats::*member;
    const char* unit;
    std::uint64_t ouster::AssemblyCounters::*from;
};

// Every counter of SensorStats once, in the order of the diagnostics' values.
inline constexpr std::array<SensorCounter, 14> kSensorCounters{{
    {"packets", &SensorStats::packets, "packets", &ouster::AssemblyCounters::packets},
    {"lidar_packets", &SensorStats::lidar_packets, "packets",
     &ouster::AssemblyCounters::lidar_packets},
    {"bad_packets", &SensorStats::bad_packets, "packets", nullptr},
    {"late_packets", &SensorStats::late_packets, "packets",
     &ouster::AssemblyCounters::late_packets},
    {"duplicate_packets", &SensorStats::duplicate_packets, "packets",
     &ouster::AssemblyCounters::duplicate_packets},
    {"crc_errors", &SensorStats::crc_errors, "packets", &ouster::AssemblyCounters::crc_errors},
    {"resets", &SensorStats::resets, "resets", &ouster::AssemblyCounters::resets},
    {"scans", &SensorStats::scans, "scans", nullptr},
    {"scans_incomplete", &SensorStats::scans_incomplete, "scans", nullptr},
    {"scans_rejected", &SensorStats::scans_rejected, "scans", nullptr},
    {"mode_mismatch_frames", &SensorStats::mode_mismatch_frames, "frames",
     &ouster::AssemblyCounters::mode_mismatch_frames},
    {"mode_mismatches", &SensorStats::mode_mismatches, "mismatches",
     &ouster::AssemblyCounters::mode_mismatches},
    {"scans_mode_rejected", &SensorStats::scans_mode_rejected, "scans", nullptr},
    {"scans_off_clock", &SensorStats::scans_off_clock, "scans", nullptr},
}};

// Every figure of PipelineStats the diagnostics publish has its row in kPipelineFigures
// (below); truncated, dds_write_timeouts and granted_receive_buffers are not published.
struct PipelineStats {
    std::uint64_t datagrams = 0, unassigned_datagrams = 0, kernel_drops = 0, truncated = 0;
    std::uint64_t scan_queue_drops = 0, frame_queue_drops = 0, result_queue_drops = 0;
    std::uint64_t frames_synchronised = 0, frames_partial = 0, scans_late = 0;
    std::uint64_t frames_fused = 0;
    // Of the frames fused, those fused at the poses predicted from the registered frames
    // (sync.when_behind: predict, while fusion was behind).
    std::uint64_t frames_predicted = 0;
    double last_fusion_ms = 0.0, mean_fusion_ms = 0.0;
    // Steady clock from the frame's last scan completing (its last packet) to its cloud
    // having been written to DDS (when DDS is off: to the output thread taking it).
    double last_latency_ms = 0.0;
    std::uint64_t dds_samples_written = 0, dds_write_failures = 0, dds_write_timeouts = 0;
    // The world frame (station.yaml `world:`): its kind, whether it is known yet, the
    // frames fused before it was (not published: their frame was not known), and its fit
    // (road: rms of the road points about the plane; geo: rms and largest distance of the
    // sensors' fitted positions from the given ones, m).
    std::string world_frame = "sensor";
    bool world_fixed = false;
    std::uint64_t frames_before_world_frame = 0;
    // How long the last initial registration took (wall clock, ms; 0 before the first).
    double last_initial_registration_ms = 0.0;
    double world_residual_rms_m = 0.0, world_residual_max_m = 0.0;
    std::vector<int> granted_receive_buffers;
    std::vector<SensorStats> sensors;
    RecorderStats record;    // output.record (enabled false when off)
    FoxgloveStats foxglove;  // output.foxglove (enabled false when off)
};

// A pipeline-wide figure of PipelineStats: its diagnostics key, the member (a count, a
// measure printed with the printf `format`, a text or a flag; the other members are null)
// and its unit ("" for a text or a flag).
struct PipelineFigure {
    const char* name;
    const char* unit;
    std::uint64_t PipelineStats::*count = nullptr;
    double PipelineStats::*measure = nullptr;
    const char* format = nullptr;
    std::string PipelineStats::*text = nullptr;
    bool PipelineStats::*flag = nullptr;

    constexpr PipelineFigure(const char* n, std::uint64_t PipelineStats::*m, const char* u)
        : name(n), unit(u), count(m) {}
    constexpr PipelineFigure(const char* n, double PipelineStats::*m, const char* f, const char* u)
        : name(n), unit(u), measure(m), format(f) {}
    constexpr PipelineFigure(const char* n, std::string PipelineStats::*m)
        : name(n), unit(""), text(m) {}
    constexpr PipelineFigure(const char* n, bool PipelineStats::*m) : name(n), unit(""), flag(m) {}
};

// Every published figure of PipelineStats once, in the order of the pipeline's diagnostics
// values (the recorder's and the live view's follow them, when on).
inline constexpr std::array<PipelineFigure, 22> kPipelineFigures{{
    {"datagrams", &PipelineStats::datagrams, "datagrams"},
    {"unassigned_datagrams", &PipelineStats::unassigned_datagrams, "datagrams"},
    {"kernel_drops", &PipelineStats::kernel_drops, "datagrams"},
    {"scan_queue_drops", &PipelineStats::scan_queue_drops, "scans"},
    {"frame_queue_drops", &PipelineStats::frame_queue_drops, "frames"},
    {"result_queue_drops", &PipelineStats::result_queue_drops, "frames"},
    {"frames_synchronised", &PipelineStats::frames_synchronised, "frames"},
    {"frames_partial", &PipelineStats::frames_partial, "frames"},
    {"scans_late", &PipelineStats::scans_late, "scans"},
    {"frames_fused", &PipelineStats::frames_fused, "frames"},
    {"frames_predicted", &PipelineStats::frames_predicted, "frames"},
    {"last_fusion_ms", &PipelineStats::last_fusion_ms, "%.2f", "ms"},
    {"mean_fusion_ms", &PipelineStats::mean_fusion_ms, "%.2f", "ms"},
    {"last_latency_ms", &PipelineStats::last_latency_ms, "%.2f", "ms"},
    {"dds_samples_written", &PipelineStats::dds_samples_written, "samples"},
    {"dds_write_failures", &PipelineStats::dds_write_failures, "samples"},
    {"world_frame", &PipelineStats::world_frame},
    {"world_frame_fixed", &PipelineStats::world_fixed},
    {"frames_before_world_frame", &PipelineStats::frames_before_world_frame, "frames"},
    {"last_initial_registration_ms", &PipelineStats::last_initial_registration_ms, "%.0f", "ms"},
    {"world_residual_rms_m", &PipelineStats::world_residual_rms_m, "%.4f", "m"},
    {"world_residual_max_m", &PipelineStats::world_residual_max_m, "%.4f", "m"},
}};

class Pipeline {
public:
    explicit Pipeline(const DaemonConfig& config);
    ~Pipeline();
    Pipeline(const Pipeline&) = delete;
    Pipeline& operator=(const Pipeline&) = delete;

    void start();
    void stop();  // idempotent; returns when every thread has ended

    PipelineStats stats() const;
    // Steady-clock time of the fusion thread's last loop (it loops at least every 100 ms).
    std::chrono::steady_clock::time_point heartbeat() const;
    // Re-open poses.csv and rewrite extrinsics.yaml (SIGHUP, after logrotate).
    void request_reopen();
    std::vector<std::uint16_t> bound_ports() const;
    // The DDS domain the publisher joined, or -1 when output.dds.enabled is false.
    int dds_domain_id() const;
    // The live view's TCP port (output.foxglove.port, or the one picked for 0), 0 when off.
    std::uint16_t foxglove_port() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace lidarfuse::daemon
