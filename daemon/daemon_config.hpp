#pragma once
// The daemon's whole configuration: station.yaml's station section (drivers/station) plus
// the network, sync, registration, dynamics, output and health sections. Every key has a
// default; config/station.schema.md documents them and config/station.example.yaml shows
// them. load_daemon_config() validates the whole file before anything starts and throws
// station::ConfigError listing every problem with its key path.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/pipeline/fusion_types.hpp"
#include "drivers/station/station_config.hpp"
#include "drivers/station/world_config.hpp"

namespace lidarfuse::daemon {

struct NetworkConfig {
    std::string bind_address = "0.0.0.0";
    int receive_buffer_bytes = 32 * 1024 * 1024;
    // How long a receiver waits after a wake-up before reading again (ms), so that a
    // sensor's datagrams are read a few at a time (net::UdpReceiverParams::coalesce_us):
    // about half the receivers' CPU for at most this much more latency (bench/BENCHMARK.md,
    // "The receivers' wake-ups"). 0: every datagram is read as it arrives.
    double receive_coalesce_ms = 5.0;
};

struct SyncConfig {
    double max_offset_ms = 0.0;  // 0: one frame period of the root sensor (1/SR)
    double deadline_ms = 75.0;   // how long a frame waits for late members
    double reset_jump_ms = 2000.0;
    // A sensor whose clock differs from the root sensor's by more than this has its scans
    // refused before synchronisation (daemon/clock_check.hpp); 0: not checked.
    double max_clock_skew_ms = 1000.0;
    // Synchronised frames waiting for the fusion thread (and fused ones for the output
    // thread); when full the oldest is dropped and counted. While fusion is slower than the
    // frame rate, a frame waits up to this many fusion times. 2: a frame that arrives while
    // another waits is not dropped but fused at predicted poses after it (when_behind); 1
    // drops more frames at the same latency, 4 and more add latency (bench/BENCHMARK.md,
    // "The frame queue's depth").
    int queue_depth = 2;
    // sync.when_behind. predict (the default): when a frame already waits as fusion
    // finishes one, the next is fused at the poses predicted from the registered frames
    // (FrameMode::kPredict) instead of registered, so that more frames are fused while
    // fusion is slower than the sensors; a predicted frame is always followed by a
    // registered one, and the engine registers a frame whose poses it cannot trust to the
    // prediction (FusionParams::prediction_*). drop: every frame is registered, and the
    // queue drops the oldest when fusion is behind. Figures: bench/BENCHMARK.md, "Frames
    // fused at predicted poses".
    bool predict_when_behind = true;
};

// DDS output (daemon/dds_publisher.hpp): topics and types follow ROS 2's DDS mapping.
struct DdsConfig {
    bool enabled = true;
    int domain_id = -1;                         // 0..232; -1: $ROS_DOMAIN_ID, or 0 when unset
    std::string topic_namespace = "lidarfuse";  // rt/<ns>/points, rt/<ns>/poses ("" = rt/points)
    // The fused frame's tf name (header.frame_id of clouds, rt/tf and poses; the sensors are
    // its children, named after them). The default has a '/', which sensor names cannot
    // have, so it never names a sensor's own frame; a config naming it after a sensor is
    // refused.
    std::string frame_id = "lidarfuse/fused";
    // Put before the fused frame and every sensor's frame (its name) in clouds, tf, poses and
    // diagnostics, e.g. "station0/": stations sharing a DDS domain then keep their tf trees
    // apart, and a segment daemon hangs each below its own frame (a DDS source's frame_id).
    std::string frame_prefix;
    int depth = 2;                 // keep-last history of every writer
    double max_blocking_ms = 5.0;  // longest a write may wait for a slow reader
    bool publish_points = true;    // rt/<ns>/points (the poses, tf and diagnostics always)
    // > 0: rt/<ns>/points_voxel too, the fused cloud thinned to one point per voxel of this
    // size (m) in the fused frame (core/pipeline/fused_cloud_voxels.hpp); 0: not published.
    double points_voxel_size_m = 0.0;
    double diagnostics_period_ms = 1000.0;
};

// output.foxglove (daemon/foxglove_server.hpp): the Foxglove WebSocket protocol for a live
// view without ROS. It sends the CDR bytes of the DDS samples, so it needs output.dds.
struct FoxgloveConfig {
    bool enabled = false;
    std::string bind_address = "127.0.0.1";  // loopback: only this host, unless opened up
    int port = 8765;                         // Foxglove's default; 0: any free port (logged)
    int max_clients = 8;                     // further connections are refused and counted
    // Bytes waiting for one client's socket; a message that would go past it is dropped for
    // that client and counted. 16 MiB holds four clouds of 4 OS1-64 (3.7 MB each, measured).
    double client_buffer_mb = 16.0;
};

// The clock of every published stamp (daemon/frame_stamps.hpp): the sensors' own (kSensor,
// PTP-synchronised stations) or the host's CLOCK_REALTIME when a scan's last packet arrived
// (kHost, sensors not synchronised with the host).
enum class StampSource { kSensor, kHost };

// output.record (daemon/recorder.hpp): every received datagram into rotating pcap files.
enum class LowDiskPolicy { kRemoveOldest, kStop };

struct RecordConfig {
    bool enabled = false;
    std::filesystem::path directory;  // empty: <output.directory>/recordings (after --output)
    // A file is closed and the next begun at this size or after this much capture time. 1 GiB
    // holds a minute of 4 OS1-64 at 1024x20 (16 MB/s each).
    double max_file_mb = 1024.0;
    double max_file_s = 300.0;
    // Free space on the recording's file system below which the oldest file of this
    // recording is removed (kRemoveOldest) or the recording stops (kStop); checked every
    // second. Either way a counter, a warning in the log and WARN in the diagnostics.
    double min_free_mb = 2048.0;
    LowDiskPolicy when_disk_low = LowDiskPolicy::kRemoveOldest;
    // Received datagrams waiting for the writer; when full they are dropped (counted), never
    // waited for. 256 MiB is 4 s of 4 OS1-64: a long stall of the disk, not a fast disk.
    double queue_mb = 256.0;
};

struct OutputConfig {
    std::filesystem::path directory = "/var/lib/lidarfuse";
    bool poses_csv = true;        // DIRECTORY/poses.csv, appended per frame
    bool extrinsics_yaml = true;  // DIRECTORY/extrinsics.yaml, rewritten atomically
    int extrinsics_interval_frames = 20;
    int record_clouds_every = 0;  // every Nth fused cloud as a file; 0 = none
    enum class CloudFormat { kPly, kPcd } record_clouds_format = CloudFormat::kPly;
    StampSource stamp = StampSource::kSensor;  // clouds, tf, poses and diagnostics on DDS
    DdsConfig dds;
    FoxgloveConfig foxglove;
    RecordConfig record;
};

struct HealthConfig {
    double stale_after_ms = 250.0;  // a sensor with no scan for this long is STALE
    double lost_after_ms = 2000.0;  // ... and LOST after this long
    // Scans below this share of columns are not fused. Above 0.5 on purpose: a sensor
    // switched from 1024 to 512 columns keeps its packet size and delivers frames exactly
    // half complete, which the 1024-column metadata would project at wrong azimuths.
    double min_completeness = 0.75;
};

struct DaemonConfig {
    station::StationConfig station;
    NetworkConfig network;
    SyncConfig sync;
    // registration + dynamics sections. Two fusion threads unless the config says otherwise:
    // one keeps up with 20 Hz only for two sensors (1 m voxels: 25 CPU ms per frame for two,
    // 61 for four; README), and the receivers run at a higher priority than both.
    core::FusionParams fusion = [] {
        core::FusionParams f;
        f.num_threads = 2;
        return f;
    }();
    // The frame clouds and poses are published in (road by default; config/station.schema.md).
    station::WorldConfig world;
    OutputConfig output;
    HealthConfig health;
    std::string log_level = "info";
};

// output.record.directory, or its default <output.directory>/recordings.
std::filesystem::path record_directory(const OutputConfig& output);

// The fused frame's tf name: output.dds.frame_prefix + output.dds.frame_id.
std::string fused_frame_of(const DdsConfig& dds);
// Each sensor's tf frame, in config order: its source.dds.frame_id where given, else
// output.dds.frame_prefix + its name.
std::vector<std::string> sensor_frames_of(const station::StationConfig& station,
                                          const DdsConfig& dds);

DaemonConfig parse_daemon_config(const std::string& yaml_text, const std::string& source_name,
                                 const std::filesystem::path& base_dir);
DaemonConfig load_daemon_config(const std::filesystem::path& file);

}  // namespace lidarfuse::daemon
