#pragma once
// output.record: every datagram the receivers take in, as it arrived, into rotating pcap
// files (libpcap's writer; capture time = the kernel's receive stamp, ns; each datagram whole
// in one Ethernet/IPv4/UDP frame, as a loopback capture holds it), with a snapshot of the
// station's configuration and every sensor's metadata beside them, so that a campaign can
// be processed again later (`lidarfuse replay FOLDER` into a daemon, `lidarfuse fuse`).
//
// One recording per daemon run: <record.directory>/<UTC start>/ with station.yaml,
// metadata/<sensor>.json and NNNNN-<UTC of the file's first datagram>.pcap, all ports in one
// time-ordered stream (the file order is the name order). The receivers only copy a datagram
// into a bounded ring and go on: a full ring drops it (counted), it is never waited for.
// Writing, rotation and the free-space checks run on the recorder's own thread.

#include <spdlog/logger.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "core/common/counter_field.hpp"
#include "daemon/daemon_config.hpp"
#include "drivers/net/udp_receiver.hpp"

namespace lidarfuse::daemon {

struct RecorderStats {
    bool enabled = false;
    bool recording = false;           // false once stopped (low disk, write error) or never begun
    std::string stopped_because;      // why recording stopped, when it did
    std::uint64_t datagrams = 0;      // written
    std::uint64_t bytes = 0;          // payload bytes written
    std::uint64_t files = 0;          // begun
    std::uint64_t files_removed = 0;  // for free space (LowDiskPolicy::kRemoveOldest)
    std::uint64_t queue_drops = 0;    // the ring was full
    std::uint64_t write_errors = 0;
    std::string folder;  // this run's recording
    std::string file;    // being written
    // What the operator should look at (stopped, files removed, drops), "" when nothing.
    std::string problem() const;
};

// Every counter of RecorderStats once, in the order of the diagnostics' values.
inline constexpr std::array<core::CounterField<RecorderStats>, 6> kRecorderCounters{{
    {"record_datagrams", &RecorderStats::datagrams, "datagrams"},
    {"record_bytes", &RecorderStats::bytes, "bytes"},
    {"record_files", &RecorderStats::files, "files"},
    {"record_files_removed", &RecorderStats::files_removed, "files"},
    {"record_queue_drops", &RecorderStats::queue_drops, "datagrams"},
    {"record_write_errors", &RecorderStats::write_errors, "errors"},
}};

// Why a recording into `directory` could not start (for `lidarfused --check`, which makes
// no folder): the nearest folder on its path that exists is not a directory this process
// may write into. "" when it can.
std::string record_directory_problem(const std::filesystem::path& directory);

class Recorder {
public:
    // Free bytes for a path's file system (tests inject a disk that fills up).
    using FreeSpace = std::function<std::uint64_t(const std::filesystem::path&)>;

    // Creates the recording's folder and its snapshot (throws naming the path when it
    // cannot) and starts the writer thread. `dst_ip` (host order) is the address written as
    // every datagram's destination (the bound address; 0 for a wildcard bind).
    Recorder(const RecordConfig& config, const station::StationConfig& station,
             std::uint32_t dst_ip, std::shared_ptr<spdlog::logger> log, FreeSpace free_space = {});
    ~Recorder();  // stop()
    Recorder(const Recorder&) = delete;
    Recorder& operator=(const Recorder&) = delete;

    // Any receiver thread: copies the datagram for the writer, or counts it dropped.
    void offer(const net::ReceivedDatagram& d);
    // A sensor's metadata fetched from its HTTP API (daemon/metadata_fetcher.hpp), from any
    // thread: the first version becomes metadata/<sensor>.json; a later, different one
    // (the sensor re-initialised) metadata/<sensor>.<UTC now>.json, which applies to the
    // datagrams recorded from then on (logged). Failures are logged, never thrown.
    void note_metadata(const std::string& sensor, const std::string& json);
    // Writes what is queued, closes the file and joins the thread. Idempotent.
    void stop();

    RecorderStats stats() const;
    const std::filesystem::path& folder() const { return folder_; }

private:
    struct Impl;
    std::filesystem::path folder_;
    std::mutex metadata_mutex_;  // note_metadata's writers
    std::unique_ptr<Impl> impl_;
};

}  // namespace lidarfuse::daemon
