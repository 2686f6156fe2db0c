#pragma once
// What lidarfused costs while daemon_latency_bench runs it, read from /proc: CPU and minor
// page faults per pipeline stage (its threads grouped by name) and the peak resident set.

#include <sys/types.h>

#include <map>
#include <string>

namespace lidarfuse::bench {

struct StageUsage {
    double cpu_s = 0.0;
    double minor_faults = 0.0;
};

// Thread CPU (s) and minor page faults of process `pid` by stage: receive (lf-recv-*),
// sync, fusion (with its OpenMP team), initial (lf-init, with its team), output, record,
// foxglove (the live view's server), main, and dds (every other thread: Cyclone's recv, tev, dq.*,
// gc, ...).
std::map<std::string, StageUsage> usage_by_stage(pid_t pid);

// The peak resident set of a process (VmHWM, MiB), 0 when unreadable.
double peak_rss_mib(pid_t pid);

// Its resident set now (VmRSS, MiB), 0 when unreadable.
double rss_mib(pid_t pid);

}  // namespace lidarfuse::bench
