#pragma once
// daemon_latency_bench's DDS reader: subscribes to lidarfused's clouds, poses and
// diagnostics (the ROS 2 types the daemon writes) with a chosen QoS, optionally from another
// network namespace, and notes when each cloud arrived.

#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace lidarfuse::bench {

// CLOCK_MONOTONIC in ns: the clock of the replay's send times and the arrival times.
std::int64_t monotonic_ns();

// How the clouds travel: Cyclone's configuration (CYCLONEDDS_URI; empty = unset) of each
// side and the reader's QoS.
struct Delivery {
    std::string daemon_uri;
    std::string reader_uri;
    bool reader_reliable = true;
    int reader_depth = 20;
    std::string reader_netns;  // empty: this process's network namespace
};

struct Received {
    std::mutex mutex;
    std::map<std::int64_t, std::int64_t> cloud_arrival_ns;  // by header stamp
    std::map<std::int64_t, std::vector<std::int64_t>>
        members;  // by stamp: included sensors' t_ns (0: absent)
    std::map<std::string, std::map<std::string, std::string>>
        last_diagnostics;  // status name -> values
    // The pipeline's frame_queue_drops as each diagnostics message reported it: (arrival,
    // count), for the drops of a stretch of the run.
    std::vector<std::pair<std::int64_t, std::uint64_t>> queue_drops_over_time;
};

// The pipeline's diagnostic status of the benches' daemons (their configs say "station: bench").
inline const char* const kBenchPipelineStatus = "lidarfuse/bench/pipeline";

// The value of `key` in diagnostic status `status` (e.g. kBenchPipelineStatus) as the last
// diagnostics received gave it; "0" before any, or where the status has no such key.
std::string diagnostic_value(Received* received, const std::string& status, const char* key);

// Reads clouds, poses and diagnostics on `domain` until `stop`, arrival times taken on
// wake-up; `matched` turns true once the clouds' writer is matched. Exits the process when
// the namespace cannot be entered.
void subscribe(int domain, const Delivery& delivery, std::atomic<bool>* stop,
               std::atomic<bool>* matched, Received* out);

}  // namespace lidarfuse::bench
