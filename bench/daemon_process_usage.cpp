#include "bench/daemon_process_usage.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <system_error>

namespace lidarfuse::bench {

namespace fs = std::filesystem;

namespace {

// The stage a thread of lidarfused works for, by its name (set in daemon/): a receiver per
// sensor, and one thread per later stage; every other thread is Cyclone's (recv, tev, dq.*,
// gc, ...).
std::string stage_of_thread(const std::string& comm) {
    if (comm.rfind("lf-recv", 0) == 0) return "receive";
    static const std::map<std::string, std::string> kStageOfThread = {
        {"lf-sync", "sync"},     {"lf-fusion", "fusion"}, {"lf-init", "initial"},
        {"lf-output", "output"}, {"lf-record", "record"}, {"lf-foxglove", "foxglove"},
        {"lidarfused", "main"}};
    const auto it = kStageOfThread.find(comm);
    return it == kStageOfThread.end() ? "dds" : it->second;
}

// A size line of /proc/<pid>/status ("VmHWM:", "VmRSS:", in kB) in MiB; 0 when unreadable.
double status_mib(pid_t pid, const std::string& field) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string key;
    while (in >> key) {
        if (key == field) {
            double kib = 0;
            in >> kib;
            return kib / 1024.0;
        }
        std::getline(in, key);
    }
    return 0.0;
}

}  // namespace

std::map<std::string, StageUsage> usage_by_stage(pid_t pid) {
    std::map<std::string, StageUsage> out;
    const double tick = static_cast<double>(::sysconf(_SC_CLK_TCK));
    std::error_code ec;
    for (const auto& task : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec)) {
        std::ifstream in(task.path() / "stat");
        std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        const auto open = text.find('('), close = text.rfind(')');
        if (open == std::string::npos || close == std::string::npos) continue;
        const std::string comm = text.substr(open + 1, close - open - 1);
        std::istringstream rest(text.substr(close + 2));
        std::string field;
        double utime = 0, stime = 0, minflt = 0;
        for (int i = 3; i <= 15 && rest >> field; ++i) {
            if (i == 10) minflt = std::stod(field);
            if (i == 14) utime = std::stod(field);
            if (i == 15) stime = std::stod(field);
        }
        const std::string stage = stage_of_thread(comm);
        out[stage].cpu_s += (utime + stime) / tick;
        out[stage].minor_faults += minflt;
    }
    return out;
}

double peak_rss_mib(pid_t pid) { return status_mib(pid, "VmHWM:"); }

double rss_mib(pid_t pid) { return status_mib(pid, "VmRSS:"); }

}  // namespace lidarfuse::bench
