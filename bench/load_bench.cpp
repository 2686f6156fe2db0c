// Load: N simulated OS1-64 (1024x20, RNG19 profile) replayed at recorded speed through
// lidarfused's Pipeline (in this process, on loopback, DDS off) for a fixed time.
// Prints `name value unit` lines:
//   load_datagrams_sent / _received, load_kernel_drops, load_packet_loss (share of sent
//   datagrams that never reached an assembler), per-sensor scans/s and incomplete scans,
//   frames synchronised / fused per second, queue drops (scan, frame, result), fusion time
//   and latency (last packet of a frame -> outputs written), RSS at start and end.
// With --series it also prints one `load_t ...` line per sample (for soak runs:
// bench/soak_run.sh) with RSS, latency and counters over time.
//
// Usage: load_bench [--sensors 8] [--seconds 60] [--sample-s 1] [--capture-s 4] [--series]
// The capture (simulated once, `--capture-s` seconds, longer than the 3.2 s an assembler
// needs to see a loop as a restart) is looped by `lidarfuse replay --loop`; each loop
// restarts the sensors' frame ids and clocks, which the daemon handles as restarts.
// Everything on the machine shares its cores: the figures say what this machine did then.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/pipeline.hpp"
#include "drivers/process_env.hpp"

namespace {

namespace fs = std::filesystem;
using namespace lidarfuse;

int run(const std::string& command, std::string* output) {
    output->clear();
    FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
    if (!pipe) return -1;
    char buffer[4096];
    while (std::fgets(buffer, sizeof buffer, pipe)) *output += buffer;
    return ::pclose(pipe);
}

double figure(const std::string& output, const std::string& name) {
    const auto at = output.find("\n" + name + " ");
    const auto start = at == std::string::npos
                           ? (output.rfind(name + " ", 0) == 0 ? 0 : std::string::npos)
                           : at + 1;
    if (start == std::string::npos) return -1.0;
    return std::atof(output.c_str() + start + name.size() + 1);
}

double rss_mib() {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("VmRSS:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
    }
    return -1.0;
}

double cpu_s() {
    rusage u{};
    ::getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace

int main(int argc, char** argv) {
    lidarfuse::drivers::keep_frame_buffers_in_heap();  // as lidarfused does
    int sensors = 8;
    double seconds = 60, sample_s = 1, capture_s = 4;
    bool series = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto next = [&] { return i + 1 < argc ? std::atof(argv[++i]) : 0.0; };
        if (a == "--sensors")
            sensors = static_cast<int>(next());
        else if (a == "--seconds")
            seconds = next();
        else if (a == "--sample-s")
            sample_s = next();
        else if (a == "--capture-s")
            capture_s = next();
        else if (a == "--series")
            series = true;
        else {
            std::fprintf(stderr,
                         "usage: load_bench [--sensors 8] [--seconds 60] [--sample-s 1] "
                         "[--capture-s 4] [--series]\n");
            return 2;
        }
    }
    const std::string tool = LIDARFUSE_TOOL_PATH;
    const fs::path dir =
        fs::temp_directory_path() / ("lidarfuse_load_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    std::string out;
    const auto t_sim = std::chrono::steady_clock::now();
    if (run(tool + " sim --scenario curve --sensors " + std::to_string(sensors) + " --seconds " +
                std::to_string(capture_s) +
                " --mode 1024x20 --profile RNG19_RFL8_SIG16_NIR16 --whole-datagrams" +
                " --threads 2 --out " + (dir / "sim").string(),
            &out) != 0) {
        std::fprintf(stderr, "load_bench: sim failed:\n%s", out.c_str());
        return 1;
    }
    std::printf("load_sim_time %.1f s\n",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t_sim).count());

    auto config = daemon::load_daemon_config(dir / "sim" / "station.yaml");
    const int base = 33000 + (::getpid() % 1000) * 10;
    std::string port_map;
    for (int k = 0; k < sensors; ++k) {
        config.station.sensors[static_cast<std::size_t>(k)].udp_port =
            static_cast<std::uint16_t>(base + k);
        port_map += " --port-map " + std::to_string(7502 + 2 * k) + ":" + std::to_string(base + k);
    }
    config.network.bind_address = "127.0.0.1";
    config.output.directory = dir / "out";
    config.output.dds.enabled = false;
    config.fusion.num_threads = 1;
    config.log_level = "warn";

    daemon::Pipeline pipeline(config);
    const double rss_start = rss_mib();
    pipeline.start();
    const double cpu_start = cpu_s();
    std::string replay_out;
    std::thread replay([&] {
        run(tool + " replay " + (dir / "sim" / "capture.pcap").string() +
                " --to 127.0.0.1 --loop --duration " + std::to_string(seconds) + port_map,
            &replay_out);
    });
    const auto start = std::chrono::steady_clock::now();
    std::vector<double> latencies;
    double rss_max = rss_start;
    for (int sample = 1;; ++sample) {
        std::this_thread::sleep_until(start + std::chrono::duration<double>(sample * sample_s));
        const double t =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (t > seconds + 0.5) break;
        const auto st = pipeline.stats();
        const double rss = rss_mib();
        rss_max = std::max(rss_max, rss);
        if (st.frames_fused > 0) latencies.push_back(st.last_latency_ms);
        if (series) {
            std::printf(
                "load_t %.1f s rss_mib %.1f latency_ms %.1f fusion_ms %.1f datagrams %llu "
                "kernel_drops %llu "
                "synchronised %llu fused %llu frame_drops %llu\n",
                t, rss, st.last_latency_ms, st.last_fusion_ms,
                static_cast<unsigned long long>(st.datagrams),
                static_cast<unsigned long long>(st.kernel_drops),
                static_cast<unsigned long long>(st.frames_synchronised),
                static_cast<unsigned long long>(st.frames_fused),
                static_cast<unsigned long long>(st.frame_queue_drops));
            std::fflush(stdout);
        }
    }
    replay.join();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    pipeline.stop();
    const double cpu = cpu_s() - cpu_start;
    const auto st = pipeline.stats();
    const double sent = figure(replay_out, "replay_datagrams_sent");
    const double duration = figure(replay_out, "replay_duration");
    std::uint64_t packets = 0, scans = 0, incomplete = 0, rejected = 0, late = 0, resets = 0;
    std::uint64_t mode_mismatches = 0, mode_rejected = 0;
    for (const auto& s : st.sensors) {
        packets += s.packets;
        scans += s.scans;
        incomplete += s.scans_incomplete;
        rejected += s.scans_rejected;
        mode_mismatches += s.mode_mismatches;
        mode_rejected += s.scans_mode_rejected;
        late += s.late_packets;
        resets += s.resets;
    }
    std::sort(latencies.begin(), latencies.end());
    const auto pct = [&](double q) {
        return latencies.empty() ? -1.0
                                 : latencies[static_cast<std::size_t>(q * (latencies.size() - 1))];
    };
    double load1 = 0;
    if (FILE* f = std::fopen("/proc/loadavg", "r")) {
        if (std::fscanf(f, "%lf", &load1) != 1) load1 = -1;
        std::fclose(f);
    }
    std::printf("load_sensors %d sensors\n", sensors);
    std::printf("load_duration %.1f s\n", duration);
    std::printf("load_datagrams_sent %.0f datagrams\n", sent);
    std::printf("load_datagrams_received %llu datagrams\n",
                static_cast<unsigned long long>(st.datagrams));
    std::printf("load_datagrams_assembled %llu datagrams\n",
                static_cast<unsigned long long>(packets));
    std::printf("load_kernel_drops %llu datagrams\n",
                static_cast<unsigned long long>(st.kernel_drops));
    std::printf("load_packet_loss %.6f share\n",
                sent > 0 ? 1.0 - static_cast<double>(st.datagrams) / sent : -1.0);
    std::printf("load_late_packets %llu packets\n", static_cast<unsigned long long>(late));
    std::printf("load_assembler_resets %llu resets\n", static_cast<unsigned long long>(resets));
    std::printf("load_scans_per_s %.2f scans/s/sensor\n",
                static_cast<double>(scans) / duration / sensors);
    std::printf("load_scans_incomplete %llu scans\n", static_cast<unsigned long long>(incomplete));
    std::printf("load_scans_rejected %llu scans\n", static_cast<unsigned long long>(rejected));
    // A sensor flagged as not matching its metadata (ModeCheck): 0 expected for simulated data.
    std::printf("load_mode_mismatches %llu times\n",
                static_cast<unsigned long long>(mode_mismatches));
    std::printf("load_scans_mode_rejected %llu scans\n",
                static_cast<unsigned long long>(mode_rejected));
    std::printf("load_frames_synchronised_per_s %.2f frames/s\n",
                static_cast<double>(st.frames_synchronised) / duration);
    std::printf("load_frames_partial %llu frames\n",
                static_cast<unsigned long long>(st.frames_partial));
    std::printf("load_frames_fused_per_s %.2f frames/s\n",
                static_cast<double>(st.frames_fused) / duration);
    std::printf("load_scan_queue_drops %llu scans\n",
                static_cast<unsigned long long>(st.scan_queue_drops));
    std::printf("load_frame_queue_drops %llu frames\n",
                static_cast<unsigned long long>(st.frame_queue_drops));
    std::printf("load_result_queue_drops %llu frames\n",
                static_cast<unsigned long long>(st.result_queue_drops));
    std::printf("load_mean_fusion_time %.1f ms\n", st.mean_fusion_ms);
    std::printf("load_latency_median %.1f ms\n", pct(0.5));
    std::printf("load_latency_p99 %.1f ms\n", pct(0.99));
    std::printf("load_cpu %.1f %%core\n", 100.0 * cpu / duration);
    std::printf("load_rss_start %.1f MiB\n", rss_start);
    std::printf("load_rss_end %.1f MiB\n", rss_mib());
    std::printf("load_rss_max %.1f MiB\n", rss_max);
    std::printf("load_machine_loadavg_1min %.2f load\n", load1);
    std::error_code ec;
    fs::remove_all(dir, ec);
    return 0;
}
