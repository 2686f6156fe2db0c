#pragma once
// Shared by the daemon-level reliability tests: a simulated station capture (with the
// simulator's fault hooks), a DaemonConfig for it on loopback ports private to this
// process, and a `lidarfuse replay` running in the background.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/pipeline.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::reliability {

// Loopback ports of a slot of this process's block (sensor k on base + k, at most 8), so
// the suites can run in parallel (tests/support/test_data.hpp).
inline std::uint16_t base_port(int slot) {
    return static_cast<std::uint16_t>(test::port_block() + slot * 8);
}

// `lidarfuse sim` into `dir` (2 sensors, 512x20, RNG19 profile so that init_id exists,
// no traffic, whole datagrams) with the given --fault specs. Returns the tool's output.
inline std::string simulate(const std::filesystem::path& dir, double seconds,
                            const std::vector<std::string>& faults, int sensors = 2,
                            const std::string& mode = "512x20") {
    std::string command = test::tool_path() + " sim --scenario straight --sensors " +
                          std::to_string(sensors) + " --seconds " + std::to_string(seconds) +
                          " --mode " + mode +
                          " --profile RNG19_RFL8_SIG16_NIR16 --no-traffic --whole-datagrams"
                          " --threads 2 --seed 3 --out " +
                          dir.string();
    for (const auto& f : faults) command += " --fault " + f;
    std::string out;
    if (test::run_command(command, &out) != 0) throw std::runtime_error("sim failed: " + out);
    return out;
}

// The simulator's station.yaml as a daemon config: loopback, ports from base_port(slot),
// no DDS (not under test here), one registration thread, output into `out_dir`.
inline daemon::DaemonConfig station_config(const std::filesystem::path& sim_dir,
                                           const std::filesystem::path& out_dir, int slot) {
    auto config = daemon::load_daemon_config(sim_dir / "station.yaml");
    for (std::size_t k = 0; k < config.station.sensors.size(); ++k) {
        config.station.sensors[k].udp_port = static_cast<std::uint16_t>(base_port(slot) + k);
    }
    config.network.bind_address = "127.0.0.1";
    config.output.directory = out_dir;
    config.output.dds.enabled = false;
    config.fusion.num_threads = 1;
    return config;
}

// --port-map arguments sending the simulator's ports (7502 + 2k) to base_port(slot) + k.
inline std::string port_map(int slot, int sensors) {
    std::string args;
    for (int k = 0; k < sensors; ++k) {
        args += " --port-map " + std::to_string(7502 + 2 * k) + ":" +
                std::to_string(base_port(slot) + k);
    }
    return args;
}

// Runs a shell command in a thread; join() returns its exit status.
class BackgroundCommand {
public:
    explicit BackgroundCommand(const std::string& command) {
        thread_ = std::thread([this, command] {
            status_ = test::run_command(command, &output_);
            done_ = true;
        });
    }
    ~BackgroundCommand() { join(); }
    int join() {
        if (thread_.joinable()) thread_.join();
        return status_;
    }
    bool done() const { return done_; }
    const std::string& output() const { return output_; }  // valid after join()

private:
    std::thread thread_;
    std::string output_;
    int status_ = -1;
    std::atomic<bool> done_{false};
};

// `lidarfuse replay CAPTURE ARGS` in a thread.
class BackgroundReplay : public BackgroundCommand {
public:
    BackgroundReplay(const std::filesystem::path& capture, const std::string& args)
        : BackgroundCommand(test::tool_path() + " replay " + capture.string() + " " + args) {}
};

// Polls `condition` every 20 ms for up to `timeout`; true as soon as it holds.
inline bool wait_for(const std::function<bool()>& condition, std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
        if (condition()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return condition();
}

}  // namespace lidarfuse::reliability
