#include "bench/daemon_bench_soak.hpp"

#include <stdio.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include "bench/daemon_process_usage.hpp"

namespace lidarfuse::bench {

namespace {

// The looped replay's command line: every sensor's capture port mapped to the daemon's.
std::string replay_command(const SoakTarget& target, const Soak& soak) {
    std::string cmd = target.tool + " replay " + target.capture.string() +
                      " --to 127.0.0.1 --loop --duration " + std::to_string(soak.minutes * 60.0);
    for (const auto& s : *target.sensors)
        cmd += " --port-map " + std::to_string(s.capture_port) + ":" + std::to_string(s.send_port);
    return cmd + " 2>/dev/null";
}

// Flat means a drift near 0.
void print_rss_drift(const std::vector<double>& rss, const std::string& tag) {
    const std::size_t q = rss.size() / 4;
    if (q == 0) {
        std::printf("daemon_soak_samples_%s %zu samples (too few for a drift)\n", tag.c_str(),
                    rss.size());
        return;
    }
    double first = 0.0, last = 0.0;
    for (std::size_t i = 0; i < q; ++i) {
        first += rss[i] / static_cast<double>(q);
        last += rss[rss.size() - 1 - i] / static_cast<double>(q);
    }
    std::printf("daemon_soak_samples_%s %zu samples\n", tag.c_str(), rss.size());
    std::printf("daemon_soak_rss_first_quarter_%s %.1f MiB\n", tag.c_str(), first);
    std::printf("daemon_soak_rss_last_quarter_%s %.1f MiB\n", tag.c_str(), last);
    std::printf("daemon_soak_rss_drift_%s %.1f MiB\n", tag.c_str(), last - first);
    std::printf("daemon_soak_rss_max_%s %.1f MiB\n", tag.c_str(),
                *std::max_element(rss.begin(), rss.end()));
}

}  // namespace

std::uint64_t soak_replay(const SoakTarget& target, const Soak& soak, const std::string& tag) {
    const std::string cmd = replay_command(target, soak);
    std::atomic<bool> done{false};
    std::uint64_t sent = 0;
    std::thread replayer([&] {
        FILE* pipe = ::popen(cmd.c_str(), "r");
        char line[256];
        unsigned long long datagrams = 0;
        while (pipe && std::fgets(line, sizeof line, pipe))
            if (std::sscanf(line, "replay_datagrams_sent %llu", &datagrams) == 1) sent = datagrams;
        if (pipe) ::pclose(pipe);
        done = true;
    });
    const auto counter = [&](const char* key) {
        return diagnostic_value(target.received, kBenchPipelineStatus, key);
    };
    std::vector<double> rss;
    const auto start = std::chrono::steady_clock::now();
    for (int k = 1;; ++k) {
        const auto due = start + std::chrono::duration<double>(k * soak.sample_s);
        while (!done.load() && std::chrono::steady_clock::now() < due)
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (done.load()) break;
        rss.push_back(rss_mib(target.daemon));
        std::printf(
            "daemon_soak_t %.0f s rss_mib %.1f frames_fused %s frames_predicted %s "
            "frames_dropped %s\n",
            k * soak.sample_s, rss.back(), counter("frames_fused").c_str(),
            counter("frames_predicted").c_str(), counter("frame_queue_drops").c_str());
        std::fflush(stdout);
    }
    replayer.join();
    print_rss_drift(rss, tag);
    return sent;
}

}  // namespace lidarfuse::bench
