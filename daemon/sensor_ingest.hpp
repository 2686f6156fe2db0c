#pragma once
// lidarfused's receiving side (DESIGN.md data flow, first stage): one Receiver per UDP
// port, its sensors routed by port, source address and serial, each sensor's packets
// assembled into scans and projected on the receiver thread, every finished scan queued
// as a ScanMessage for the sync thread. Counters are atomics (or, for the assembler's,
// a copy under a mutex refreshed every 64 packets) so other threads can read them.

#include <spdlog/logger.h>

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "daemon/buffer_pool.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/drop_oldest_queue.hpp"
#include "daemon/metadata_status.hpp"
#include "daemon/recorder.hpp"
#include "drivers/net/udp_receiver.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/projection.hpp"
#include "drivers/ouster/scan_assembler.hpp"
#include "drivers/ouster/sensor_router.hpp"
#include "drivers/ouster/xyz_lut.hpp"

namespace lidarfuse::daemon {

// Host clocks, ns: steady for time-outs and latency, real time for the sensors' clock
// offset (a diagnostic) and for the stamps of `output.stamp: host`.
std::int64_t steady_ns();
std::int64_t realtime_ns();

struct ScanMessage {
    std::size_t sensor = 0;
    std::int64_t t_ns = 0;
    std::int64_t complete_steady_ns = 0;    // when the scan's last packet had been assembled
    std::int64_t complete_realtime_ns = 0;  // the same moment on CLOCK_REALTIME
    std::vector<Eigen::Vector3f> points;    // as core::SensorScanInput's
    std::vector<float> point_dt_s;
    std::vector<float> intensity;
};

// Scans kept per sensor for reuse (BufferPool). Keeping up, fusion hands frame k's scan back
// before the sensor's next one completes, so one covers the steady state; more would only
// hold memory (1.3 MB an OS1-64 scan) while fusion is behind, when scans are dropped anyway.
inline constexpr std::size_t kSpareScansPerSensor = 1;

// Everything the receiving thread owns for one sensor; counters read by other threads.
struct SensorIngest {
    std::size_t index = 0;
    std::string name;
    std::int64_t time_offset_ns = 0;
    ouster::SensorInfo info;
    ouster::XyzLut lut;
    std::unique_ptr<ouster::ScanAssembler> assembler;
    ouster::ScanCloud cloud;
    std::atomic<std::uint64_t> scans{0}, scans_incomplete{0}, scans_rejected{0};
    // Scans not fused because the data disagrees with the metadata's mode (ModeCheck).
    std::atomic<std::uint64_t> scans_mode_rejected{0};
    std::atomic<bool> mode_mismatch{false};
    // Scans refused because the sensor's clock disagrees with the root's (ClockCheck, on the
    // sync thread): how many, whether the latest scan was, and by how much it differed (ns).
    std::atomic<std::uint64_t> scans_off_clock{0};
    std::atomic<bool> clock_skewed{false};
    std::atomic<std::int64_t> clock_skew_ns{0};
    std::atomic<std::int64_t> last_scan_steady_ns{0};
    std::atomic<std::int64_t> clock_offset_ns{0};  // sensor clock - host clock at the last scan
    std::atomic<double> last_completeness{0.0};
    mutable std::mutex counters_mutex;  // guards `counters` (a copy of the assembler's) and
    ouster::AssemblyCounters counters;  // `mode_seen`
    std::string mode_seen;  // what disagreed with the metadata, set when mode_mismatch is
    std::uint32_t packets_since_publish = 0;  // receiver thread only
    // Scans fusion is done with, for the producer's next ones (receiver thread or DdsInput).
    BufferPool<ScanMessage> spare_scans{kSpareScansPerSensor};
    // A message to fill: a spare one, its vectors empty but keeping their capacity, or a
    // new one when none is kept.
    ScanMessage take_spare_scan();

    // Metadata. A sensor with a file has it from the start; one named by hostname gets it
    // from its MetadataFetcher (daemon/metadata_fetcher.hpp), which hands every version to
    // the receiver thread here; the receiver installs it at its next datagram.
    bool has_info = false;                         // receiver thread (and the constructor)
    std::uint16_t udp_port = 0;                    // station.yaml's, which wins over the metadata's
    ouster::AssemblyCounters counters_before;      // receiver thread: earlier assemblers' sum
    std::atomic<bool> metadata_known{false};       // has_info, for other threads
    std::atomic<int> frames_per_second{0};         // of the installed metadata; 0 before
    std::atomic<std::uint32_t> packet_init_id{0};  // of the latest scan (0: LEGACY headers)
    std::atomic<bool> has_pending{false};
    std::mutex pending_mutex;  // guards pending_info
    std::optional<ouster::SensorInfo> pending_info;
    // Takes `next` as the sensor's metadata (the station's port wins over its own) with its
    // LUT; before the receiver thread starts, or on it.
    void adopt_metadata(ouster::SensorInfo next);
    // Receiver thread: installs pending metadata (new LUT and assembler); true if it did.
    bool install_pending_metadata(double min_completeness, DropOldestQueue<ScanMessage>* queue);

    // The fetcher's state, for the stats (under counters_mutex).
    MetadataStatus metadata_status;
};

struct Receiver {
    std::unique_ptr<net::UdpReceiver> socket;
    std::vector<SensorIngest*> sensors;  // on this port
    // Routes among the members with metadata (a sensor waiting for its metadata cannot be
    // told apart: its datagrams are unassigned until it has some); router index -> member.
    std::unique_ptr<ouster::SensorRouter> router;
    std::vector<std::size_t> routed_members;
    const station::StationConfig* station = nullptr;
    double min_completeness = 0.0;
    DropOldestQueue<ScanMessage> queue{8};
    std::atomic<std::uint64_t> unassigned{0};
    std::shared_ptr<spdlog::logger> log;  // mode mismatch flagged / cleared (rare events)
    Recorder* recorder = nullptr;         // output.record: gets every datagram, routed or not
    std::thread thread;
};

// Binds `port` (throws naming it) for `members`, routed by the station's source addresses,
// and gives each member its assembler feeding the receiver's queue; scans below
// `min_completeness` are counted as rejected and not queued, and so are scans while the
// sensor's data disagrees with its metadata's mode (ScanAssembler::mode_check()).
std::unique_ptr<Receiver> make_receiver(std::uint16_t port,
                                        const std::vector<SensorIngest*>& members,
                                        const NetworkConfig& network,
                                        const station::StationConfig& station,
                                        double min_completeness);

// The receiver thread's body: returns when the socket is stopped. Logs (r->log) when a
// sensor's data starts or stops disagreeing with its metadata's mode.
void run_receiver(Receiver* r);

// Copies the assembler's counters for other threads (the receiver thread, or after it ended).
void publish_counters(SensorIngest* s);

}  // namespace lidarfuse::daemon
