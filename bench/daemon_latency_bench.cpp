// lidarfused end to end on loopback: a simulated station of N OS1-64 (1024x20) is replayed at
// recorded speed through the daemon's sockets while this process subscribes over DDS.
// Prints `name value unit` lines per N:
//   latency from the last packet of a frame (the send of the last datagram of the frame's
//     last-completed scan) to its fused cloud arriving at the DDS reader: median and p99
//   CPU and minor page faults per stage over the replay (% of one core and faults/s, from
//     /proc/<pid>/task: lf-recv-*, lf-sync, lf-fusion (with its OpenMP team), lf-init (the
//     initial registration, with its team), lf-output, lf-record, Cyclone's threads, the
//     rest), and the peak RSS
//   the same latency and the frames dropped over the steady run alone (from kSettleS after
//     the first cloud), besides the whole run's
//   packets sent, received (diagnostics), lost; frames in the capture, fused, published
// and at the end the largest N with zero packet loss and the largest N that also fused at
// least 95 % of the capture's frames (real time).
//
// Usage: daemon_latency_bench [--sensors 2,4,6,8] [--seconds 5] [--scenario curve]
//                             [--queue-depth N]   (sync.queue_depth; default: the daemon's, 2)
//                             [--fusion-threads N]  (registration.threads; default: the daemon's,
//                             2)
//                             [--record 1]        (output.record on: the recorder's CPU and drops)
//                             [--foxglove off|server|client]  (output.foxglove: off; the live
//                                 view's server on with no client; or with a Node client
//                                 subscribed to every channel, bench/foxglove_bench_client.hpp)
//                             [--when-behind predict|drop]  (sync.when_behind; default: the
//                                 daemon's, predict)
//                             [--receive-coalesce-ms MS]  (network.receive_coalesce_ms;
//                                 default: the daemon's, 5)
//                             [--soak-minutes M [--sample-s 30]]  (the --seconds capture looped
//                                 for M minutes by `lidarfuse replay --loop`: the daemon's RSS
//                                 every sample-s seconds, as `daemon_soak_t` lines, and its drift
//                                 from the first to the last quarter; no latency figures)
//                             [--keep 1]          (leave the folder: daemon logs, outputs)
//                             [--daemon PATH]     (another lidarfused, e.g. a build of the
//                                 parent commit, for side-by-side runs; default: the one
//                                 built beside this bench)
//                             [--cyclonedds bench|default|FILE]  (Cyclone's configuration of the
//                                 daemon and the reader: bench = loopback with 64 kB fragments,
//                                 below; default = none, Cyclone's defaults; FILE, e.g.
//                                 config/cyclonedds.xml)
//                             [--reader-cyclonedds bench|default|FILE]  (the reader's alone)
//                             [--reader-qos reliable|best-effort] [--reader-depth 20]
//                             [--reader-netns NAME]  (the reader in network namespace NAME, as
//                                 on another host: `ip netns add`, a veth pair between them,
//                                 and Cyclone configurations that name each side's interface)
//   (--reader-qos best-effort --reader-depth 5 is ROS 2's sensor-data QoS, reliable 10 its
//   default; clouds delivered = received / published, published = fused after the world
//   frame was fixed)
// Needs the built `lidarfuse` (sim) and `lidarfused` beside it (build/tools, build/daemon).
// The replay runs in this process (one thread); the machine's other load shares the cores.
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/daemon_bench_launch.hpp"
#include "bench/daemon_bench_replay.hpp"
#include "bench/daemon_bench_soak.hpp"
#include "bench/daemon_process_usage.hpp"
#include "bench/dds_bench_reader.hpp"
#include "bench/foxglove_bench_client.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"

namespace {

// The steady run starts this long after the first cloud arrives (s): the initial
// registration's result is applied and publishing starts in the same frame, and the frames
// of the next second or so cost several times a steady frame.
constexpr double kSettleS = 2.0;

using namespace lidarfuse;
using bench::children_cpu_s;
using bench::cyclone_uri;
using bench::Delivery;
using bench::monotonic_ns;
using bench::peak_rss_mib;
using bench::percentile;
using bench::process_cpu_s;
using bench::Received;
using bench::SensorReplay;
using bench::set_cyclone_uri;
using bench::Soak;
using bench::StageUsage;
using bench::start_daemon;
using bench::stop_daemon;
using bench::usage_by_stage;
namespace fs = std::filesystem;

std::string tool_dir() { return fs::path(LIDARFUSE_TOOL_PATH).parent_path().string(); }

enum class FoxgloveMode { kOff, kServer, kClient };

// What the bench's daemon config sets; the rest is the daemon's defaults.
struct DaemonSettings {
    int queue_depth = 0;      // 0: the daemon's default (sync.queue_depth)
    int fusion_threads = 0;   // 0: the daemon's default (registration.threads)
    std::string when_behind;  // "": the daemon's default (sync.when_behind)
    bool record = false;      // --record 1: output.record on (into the bench's folder)
    FoxgloveMode foxglove = FoxgloveMode::kOff;
    double receive_coalesce_ms = -1;  // < 0: the daemon's default (network.receive_coalesce_ms)
    std::string executable = bench::built_daemon_path();  // the lidarfused that runs
};

// The sync section's keys the bench sets; the others are the daemon's defaults.
std::string sync_settings(const DaemonSettings& settings) {
    std::string keys;
    const auto add = [&](const std::string& key, const std::string& value) {
        keys += (keys.empty() ? "" : ", ") + key + ": " + value;
    };
    if (settings.queue_depth > 0) add("queue_depth", std::to_string(settings.queue_depth));
    if (!settings.when_behind.empty()) add("when_behind", settings.when_behind);
    return keys;
}

// Frames dropped from the first diagnostics report at or after from_ns to the last one
// (0 when none came after from_ns).
std::uint64_t drops_since(const std::vector<std::pair<std::int64_t, std::uint64_t>>& reports,
                          std::int64_t from_ns) {
    const auto first = std::find_if(reports.begin(), reports.end(),
                                    [&](const auto& r) { return r.first >= from_ns; });
    if (first == reports.end()) return 0;
    return reports.back().second - first->second;
}

struct RunResult {
    bool ok = false;
    std::uint64_t lost = 0;
    double fused_share = 0.0;
};

// The poses the daemon wrote (poses.csv: every fused frame after the world frame, predicted
// ones included) against the simulator's truth, as `lidarfuse eval` prints them.
void print_accuracy(const fs::path& sim, const fs::path& out_dir, const std::string& tag) {
    const std::string cmd =
        tool_dir() + "/lidarfuse eval --gt " + (sim / "ground_truth.csv").string() + " --poses " +
        (out_dir / "poses.csv").string() +
        " 2>/dev/null | grep -E 'mean_(strict_)?rmse_(trans|rot)' | sed 's/^/daemon_" + tag + "_/'";
    if (std::system(cmd.c_str()) != 0) std::printf("daemon_eval_failed_%s 1 run\n", tag.c_str());
    std::fflush(stdout);
}

// Latency from the last packet of a frame to its cloud at the reader, over the whole run and
// over its steady part.
void print_latency(const std::vector<double>& latency_ms,
                   const std::vector<double>& steady_latency_ms, const std::string& tag) {
    std::printf("daemon_latency_median_%s %.1f ms\n", tag.c_str(), percentile(latency_ms, 0.5));
    std::printf("daemon_latency_p99_%s %.1f ms\n", tag.c_str(), percentile(latency_ms, 0.99));
    std::printf("daemon_latency_samples_%s %zu frames\n", tag.c_str(), latency_ms.size());
    std::printf("daemon_latency_median_steady_%s %.1f ms\n", tag.c_str(),
                percentile(steady_latency_ms, 0.5));
    std::printf("daemon_latency_p99_steady_%s %.1f ms\n", tag.c_str(),
                percentile(steady_latency_ms, 0.99));
    std::printf("daemon_latency_samples_steady_%s %zu frames\n", tag.c_str(),
                steady_latency_ms.size());
}

// The clouds the reader received against those published (fused after the world frame).
void print_delivery(const Received& received, std::size_t fused, std::size_t before_world,
                    const std::string& tag) {
    const std::size_t published = fused > before_world ? fused - before_world : 0;
    std::printf("daemon_clouds_received_%s %zu frames\n", tag.c_str(),
                received.cloud_arrival_ns.size());
    std::printf("daemon_clouds_published_%s %zu frames\n", tag.c_str(), published);
    std::printf("daemon_clouds_delivered_%s %.1f %%\n", tag.c_str(),
                published > 0 ? 100.0 * static_cast<double>(received.cloud_arrival_ns.size()) /
                                    static_cast<double>(published)
                              : 0.0);
}

RunResult run(const fs::path& sim, int n, int domain, const DaemonSettings& settings,
              const Delivery& delivery, const Soak& soak) {
    RunResult result;
    const fs::path out_dir = sim / ("out" + std::to_string(n));
    std::ofstream config(sim / ("daemon" + std::to_string(n) + ".yaml"));
    config << "station: bench\nroot: lidar0\nsensors:\n";
    std::vector<SensorReplay> sensors;
    for (int s = 0; s < n; ++s) {
        const auto info = ouster::load_metadata(sim / ("lidar" + std::to_string(s) + ".json"));
        const auto bound = static_cast<std::uint16_t>(46000 + (::getpid() % 500) * 16 + 2 * s);
        config << "  - {name: lidar" << s << ", udp_port: " << bound << ", metadata: lidar" << s
               << ".json}\n";
        sensors.push_back(SensorReplay{static_cast<std::uint16_t>(info.udp_port_lidar),
                                       bound,
                                       ::socket(AF_INET, SOCK_DGRAM, 0),
                                       ouster::PacketFormat(info),
                                       {},
                                       0});
    }
    config << "network: {bind_address: 127.0.0.1"
           << (settings.receive_coalesce_ms < 0
                   ? ""
                   : ", receive_coalesce_ms: " + std::to_string(settings.receive_coalesce_ms))
           << "}\nsync: {" << sync_settings(settings)
           << "}\noutput:\n  directory: " << out_dir.string() << "\n  dds: {domain_id: " << domain
           << ", frame_id: station, diagnostics_period_ms: 500}\n";
    if (settings.record)
        config << "  record: {enabled: true, directory: "
               << (sim / ("rec" + std::to_string(n))).string() << "}\n";
    if (settings.foxglove != FoxgloveMode::kOff) config << "  foxglove: {enabled: true, port: 0}\n";
    if (settings.fusion_threads > 0)
        config << "registration: {threads: " << settings.fusion_threads << "}\n";
    config.close();

    const pid_t pid =
        start_daemon(settings.executable, sim / ("daemon" + std::to_string(n) + ".yaml"),
                     sim / ("daemon" + std::to_string(n) + ".log"), delivery.daemon_uri);
    Received received;
    std::atomic<bool> stop{false}, matched{false};
    set_cyclone_uri(delivery.reader_uri);
    std::thread reader([&] { subscribe(domain, delivery, &stop, &matched, &received); });
    for (int i = 0; i < 1000 && !matched.load(); ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    bench::FoxgloveBenchClient viewer;
    if (settings.foxglove == FoxgloveMode::kClient) {
        const fs::path log = sim / ("daemon" + std::to_string(n) + ".log");
        std::uint16_t port = 0;
        for (int i = 0; i < 500 && port == 0; ++i) {
            port = bench::foxglove_port_in_log(log);
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        if (port == 0 || !viewer.start(port, sim / ("foxglove" + std::to_string(n) + ".json")))
            std::fprintf(stderr, "daemon_latency_bench: measuring without the Foxglove client\n");
    }
    const auto cpu0 = usage_by_stage(pid);
    const double harness_cpu0_s = process_cpu_s() + children_cpu_s();
    const std::int64_t t0 = monotonic_ns();
    const std::string tag = std::to_string(n) + "sensors";
    std::uint64_t soak_sent = 0;
    if (soak.minutes > 0)
        soak_sent = bench::soak_replay(
            {tool_dir() + "/lidarfuse", sim / "capture.pcap", &sensors, pid, &received}, soak, tag);
    else
        replay(sim / "capture.pcap", &sensors);
    const double wall_s = static_cast<double>(monotonic_ns() - t0) * 1e-9;
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // fusion catches up
    const auto cpu1 = usage_by_stage(pid);
    const double harness_cpu_s = process_cpu_s() + children_cpu_s() - harness_cpu0_s;
    const double rss_mib = peak_rss_mib(pid);
    const bench::FoxgloveCounts viewed = viewer.stop();
    const bool exited_cleanly = stop_daemon(pid);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    stop = true;
    reader.join();
    for (auto& s : sensors) ::close(s.socket);

    // Latency: cloud arrival - the last datagram of the frame's latest scan. Also over the
    // steady run alone: from kSettleS after the first cloud (the initial registration is
    // applied and publishing starts then, at once: bench/BENCHMARK.md, "The daemon's first
    // second after the initial registration").
    std::vector<double> latency_ms, steady_latency_ms;
    const std::int64_t steady_from_ns =
        received.cloud_arrival_ns.empty()
            ? 0
            : std::min_element(
                  received.cloud_arrival_ns.begin(), received.cloud_arrival_ns.end(),
                  [](const auto& a, const auto& b) {
                      return a.second < b.second;
                  })->second +
                  static_cast<std::int64_t>(kSettleS * 1e9);
    for (const auto& [stamp, arrival] : received.cloud_arrival_ns) {
        const auto members = received.members.find(stamp);
        if (members == received.members.end()) continue;
        std::int64_t last_packet = 0;
        for (std::size_t s = 0; s < members->second.size() && s < sensors.size(); ++s) {
            const std::int64_t t = members->second[s];
            if (t == 0) continue;
            for (const auto& [frame_id, scan] : sensors[s].scans) {
                if (static_cast<std::int64_t>(scan.reference_ns) == t)
                    last_packet = std::max(last_packet, scan.last_send_ns);
            }
        }
        if (last_packet == 0) continue;
        latency_ms.push_back(static_cast<double>(arrival - last_packet) * 1e-6);
        if (arrival >= steady_from_ns) steady_latency_ms.push_back(latency_ms.back());
    }
    std::uint64_t sent = soak_sent, received_packets = 0;
    std::size_t capture_frames = 0;
    for (std::size_t s = 0; s < sensors.size(); ++s) {
        sent += sensors[s].datagrams;
        capture_frames = std::max(capture_frames, sensors[s].scans.size());
        const auto it = received.last_diagnostics.find("lidarfuse/bench/lidar" + std::to_string(s));
        if (it != received.last_diagnostics.end())
            received_packets += std::stoull(it->second.at("packets"));
    }
    const auto value = [&](const char* key) {
        return bench::diagnostic_value(&received, bench::kBenchPipelineStatus, key);
    };
    // A looped capture repeats its scans' stamps: the latency of a cloud is not defined.
    if (soak.minutes <= 0) print_latency(latency_ms, steady_latency_ms, tag);
    for (const char* stage :
         {"receive", "sync", "fusion", "initial", "output", "record", "foxglove", "dds", "main"}) {
        const StageUsage before = cpu0.count(stage) ? cpu0.at(stage) : StageUsage{};
        const StageUsage after = cpu1.count(stage) ? cpu1.at(stage) : before;
        std::printf("daemon_cpu_%s_%s %.1f %%\n", stage, tag.c_str(),
                    100.0 * (after.cpu_s - before.cpu_s) / (wall_s + 1.5));
        std::printf("daemon_page_faults_%s_%s %.0f faults/s\n", stage, tag.c_str(),
                    (after.minor_faults - before.minor_faults) / (wall_s + 1.5));
    }
    // The replay and the reader share the 2 cores with the daemon: what they took of them
    // (a soak's replay is a child process, counted once it has been waited for).
    std::printf("daemon_bench_harness_cpu_%s %.1f %%\n", tag.c_str(),
                100.0 * harness_cpu_s / (wall_s + 1.5));
    std::printf("daemon_peak_rss_%s %.1f MiB\n", tag.c_str(), rss_mib);
    const std::uint64_t lost = sent > received_packets ? sent - received_packets : 0;
    std::printf("daemon_packets_sent_%s %llu packets\n", tag.c_str(),
                static_cast<unsigned long long>(sent));
    std::printf("daemon_packets_lost_%s %llu packets\n", tag.c_str(),
                static_cast<unsigned long long>(lost));
    std::printf("daemon_kernel_drops_%s %s packets\n", tag.c_str(), value("kernel_drops").c_str());
    const std::size_t fused = std::stoull(value("frames_fused"));
    if (soak.minutes <= 0)
        std::printf("daemon_frames_in_capture_%s %zu frames\n", tag.c_str(), capture_frames);
    std::printf("daemon_frames_fused_%s %zu frames\n", tag.c_str(), fused);
    std::printf("daemon_frames_predicted_%s %s frames\n", tag.c_str(),
                value("frames_predicted").c_str());
    std::printf("daemon_frames_dropped_before_fusion_%s %s frames\n", tag.c_str(),
                value("frame_queue_drops").c_str());
    std::printf("daemon_frames_dropped_steady_%s %llu frames\n", tag.c_str(),
                static_cast<unsigned long long>(
                    drops_since(received.queue_drops_over_time, steady_from_ns)));
    std::printf("daemon_initial_registration_%s %s ms\n", tag.c_str(),
                value("last_initial_registration_ms").c_str());
    // The reader keys clouds by stamp, which a looped capture repeats.
    if (soak.minutes <= 0)
        print_delivery(received, fused, std::stoull(value("frames_before_world_frame")), tag);
    std::printf("daemon_mean_fusion_%s %s ms\n", tag.c_str(), value("mean_fusion_ms").c_str());
    std::printf("daemon_dds_write_failures_%s %s writes\n", tag.c_str(),
                value("dds_write_failures").c_str());
    if (settings.foxglove != FoxgloveMode::kOff) {
        std::printf("daemon_foxglove_messages_sent_%s %s messages\n", tag.c_str(),
                    value("foxglove_messages_sent").c_str());
        std::printf("daemon_foxglove_messages_dropped_%s %s messages\n", tag.c_str(),
                    value("foxglove_messages_dropped").c_str());
        std::printf("daemon_foxglove_queue_drops_%s %s messages\n", tag.c_str(),
                    value("foxglove_queue_drops").c_str());
        std::printf("daemon_foxglove_client_clouds_%s %ld frames\n", tag.c_str(), viewed.clouds);
        std::printf("daemon_foxglove_client_cloud_bytes_%s %.1f MiB\n", tag.c_str(),
                    viewed.cloud_mib);
    }
    if (settings.record) {
        std::printf("daemon_record_datagrams_%s %s datagrams\n", tag.c_str(),
                    value("record_datagrams").c_str());
        std::printf("daemon_record_queue_drops_%s %s datagrams\n", tag.c_str(),
                    value("record_queue_drops").c_str());
    }
    std::fflush(stdout);
    if (soak.minutes <= 0) print_accuracy(sim, out_dir, tag);
    result.ok = exited_cleanly && received_packets > 0;
    result.lost = lost + std::stoull(value("kernel_drops"));
    result.fused_share =
        capture_frames ? static_cast<double>(fused) / static_cast<double>(capture_frames) : 0.0;
    return result;
}

}  // namespace

int main(int argc, char** argv) {
    std::vector<int> counts = {2, 4, 6, 8};
    double seconds = 5.0;
    std::string scenario = "curve";
    DaemonSettings settings;
    Soak soak;
    bool keep = false;  // --keep 1: leave the capture, configs, daemon logs and outputs
    Delivery delivery;
    delivery.daemon_uri = delivery.reader_uri = cyclone_uri("bench");
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string arg = argv[i];
        if (arg == "--sensors") {
            counts.clear();
            std::stringstream list(argv[i + 1]);
            std::string item;
            while (std::getline(list, item, ',')) counts.push_back(std::stoi(item));
        } else if (arg == "--seconds") {
            seconds = std::stod(argv[i + 1]);
        } else if (arg == "--queue-depth") {
            settings.queue_depth = std::stoi(argv[i + 1]);
        } else if (arg == "--fusion-threads") {
            settings.fusion_threads = std::stoi(argv[i + 1]);
        } else if (arg == "--when-behind") {
            settings.when_behind = argv[i + 1];
        } else if (arg == "--scenario") {
            scenario = argv[i + 1];
        } else if (arg == "--record") {
            settings.record = argv[i + 1] == std::string("1");
        } else if (arg == "--foxglove") {
            const std::string mode = argv[i + 1];
            settings.foxglove = mode == "client"   ? FoxgloveMode::kClient
                                : mode == "server" ? FoxgloveMode::kServer
                                                   : FoxgloveMode::kOff;
        } else if (arg == "--receive-coalesce-ms") {
            settings.receive_coalesce_ms = std::stod(argv[i + 1]);
        } else if (arg == "--daemon") {
            settings.executable = argv[i + 1];
        } else if (arg == "--soak-minutes") {
            soak.minutes = std::stod(argv[i + 1]);
        } else if (arg == "--sample-s") {
            soak.sample_s = std::stod(argv[i + 1]);
        } else if (arg == "--keep") {
            keep = argv[i + 1] == std::string("1");
        } else if (arg == "--cyclonedds") {
            delivery.daemon_uri = delivery.reader_uri = cyclone_uri(argv[i + 1]);
        } else if (arg == "--reader-cyclonedds") {
            delivery.reader_uri = cyclone_uri(argv[i + 1]);
        } else if (arg == "--reader-qos") {
            delivery.reader_reliable = argv[i + 1] != std::string("best-effort");
        } else if (arg == "--reader-depth") {
            delivery.reader_depth = std::stoi(argv[i + 1]);
        } else if (arg == "--reader-netns") {
            delivery.reader_netns = argv[i + 1];
        }
    }
    const int max_n = *std::max_element(counts.begin(), counts.end());
    const fs::path sim =
        fs::temp_directory_path() / ("daemon_latency_bench_" + std::to_string(::getpid()));
    const std::string cmd = tool_dir() + "/lidarfuse sim --scenario " + scenario + " --sensors " +
                            std::to_string(max_n) + " --seconds " + std::to_string(seconds) +
                            " --out " + sim.string() + " > /dev/null 2>&1";
    if (std::system(cmd.c_str()) != 0) {
        std::fprintf(stderr, "daemon_latency_bench: %s failed\n", cmd.c_str());
        return 1;
    }
    const int domain = 1 + static_cast<int>(::getpid() % 230);
    int max_zero_loss = 0, max_realtime = 0;
    for (int n : counts) {
        const auto r = run(sim, n, domain, settings, delivery, soak);
        if (r.ok && r.lost == 0) max_zero_loss = std::max(max_zero_loss, n);
        if (r.ok && r.lost == 0 && r.fused_share >= 0.95) max_realtime = std::max(max_realtime, n);
    }
    std::printf("daemon_max_sensors_zero_packet_loss %d sensors\n", max_zero_loss);
    std::printf("daemon_max_sensors_realtime_95pct_fused %d sensors\n", max_realtime);
    if (keep) {
        std::fprintf(stderr, "daemon_latency_bench: kept %s (daemon logs, outputs)\n", sim.c_str());
        return 0;
    }
    std::error_code ec;
    fs::remove_all(sim, ec);
    return 0;
}
