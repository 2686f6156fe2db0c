#pragma once
// What the daemon benches (daemon_latency_bench, segment_latency_bench) share: a lidarfused
// started as a child with its own log and Cyclone configuration, stopped by SIGTERM; the
// Cyclone configurations they offer; and the figures they print alike.

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace lidarfuse::bench {

// The lidarfused built beside this bench (LIDARFUSE_TOOL_PATH names the lidarfuse beside it).
std::string built_daemon_path();

// Starts `executable --config config` with stdout and stderr in `log` and CYCLONEDDS_URI =
// cyclone_uri (empty: unset). The child gets SIGTERM when this process dies, so a bench
// killed never leaves a daemon running into the next measurement. Returns its pid.
pid_t start_daemon(const std::string& executable, const std::filesystem::path& config,
                   const std::filesystem::path& log, const std::string& cyclone_uri);

// SIGTERM, then waits for it; true when it exited with status 0.
bool stop_daemon(pid_t pid);

// CYCLONEDDS_URI = uri in this process (empty: unset), read by the next participant of a
// domain that does not exist yet.
void set_cyclone_uri(const std::string& uri);

// --cyclonedds CHOICE: "bench" (loopback, 64 kB fragments), "default" (unset) or a file.
std::string cyclone_uri(const std::string& choice);

// CPU time of this process (s): what the bench's own threads took of the cores.
double process_cpu_s();

// CPU time (s) of this process's children that have been waited for (the sim, a soak's
// replay; a daemon only once it is stopped).
double children_cpu_s();

// The p-quantile (0..1) of v, nearest rank; 0 when empty.
double percentile(std::vector<double> v, double p);

}  // namespace lidarfuse::bench
