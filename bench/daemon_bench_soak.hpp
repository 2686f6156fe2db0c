#pragma once
// daemon_latency_bench --soak-minutes: lidarfused under a capture looped by `lidarfuse replay
// --loop` for minutes instead of one pass (each pass restarts the sensors' frame ids and
// clocks, which the daemon takes as restarts), its resident set sampled as it runs.

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/daemon_bench_replay.hpp"
#include "bench/dds_bench_reader.hpp"

namespace lidarfuse::bench {

struct Soak {
    double minutes = 0.0;  // 0: no soak, one pass with the latency figures
    double sample_s = 30.0;
};

// Where the looped replay sends and whom it watches.
struct SoakTarget {
    std::string tool;                          // the `lidarfuse` executable
    std::filesystem::path capture;             // the capture to loop
    const std::vector<SensorReplay>* sensors;  // capture port -> the daemon's port
    pid_t daemon;
    Received* received;  // the bench reader's diagnostics (kBenchPipelineStatus)
};

// Runs the looped replay for soak.minutes, printing a `daemon_soak_t` line per sample (RSS
// now, the pipeline's frame counters), then the mean RSS of the first and last quarter of
// the samples, their drift and maximum (`daemon_soak_*_<tag>`); returns the datagrams sent.
std::uint64_t soak_replay(const SoakTarget& target, const Soak& soak, const std::string& tag);

}  // namespace lidarfuse::bench
