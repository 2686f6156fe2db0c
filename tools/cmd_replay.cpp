// `lidarfuse replay CAPTURE.pcap|RECORDING [--to HOST] [--port-map ORIG:NEW ...]
//  [--rate R | --max-rate] [--loop [--passes N]] [--duration S]`: sends every UDP datagram of
//  a capture (or of a recording folder's files, in order) to HOST.
#include <signal.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "drivers/net/ipv4_address.hpp"
#include "drivers/pcap/replay.hpp"
#include "tools/args.hpp"
#include "tools/command.hpp"
#include "tools/progress.hpp"

namespace lidarfuse::tools {

namespace {

std::atomic<bool> g_stop{false};

extern "C" void on_stop_signal(int) { g_stop.store(true); }

std::uint16_t parse_port(const std::string& text, const std::string& option) {
    std::size_t used = 0;
    long value = -1;
    try {
        value = std::stol(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used != text.size() || value < 1 || value > 65535) {
        throw UsageError(option + " expects ports 1-65535 as ORIG:NEW, got '" + text + "'");
    }
    return static_cast<std::uint16_t>(value);
}

const char* const kUsage =
    "usage: lidarfuse replay CAPTURE.pcap|RECORDING [--to HOST] [--port-map ORIG:NEW ...]\n"
    "                        [--rate R | --max-rate] [--loop [--passes N]] [--duration S]\n"
    "                        [--quiet]\n"
    "Sends every UDP datagram of the capture (lidar and IMU; IP fragments reassembled)\n"
    "or of a recording folder of lidarfused (output.record: its .pcap files in order)\n"
    "to HOST (default 127.0.0.1) on its original destination port, or NEW for a port\n"
    "mapped with --port-map ORIG:NEW (repeatable). Timing follows the capture clock,\n"
    "sped up by --rate R (2 = twice as fast), or --max-rate sends as fast as possible.\n"
    "--loop starts over at the end until Ctrl-C, --passes N or --duration S (seconds).\n"
    "Each original sender gets its own source port. Prints a summary as `name value "
    "unit`.\nOn a terminal, a progress line on stderr (datagrams, share of the file or "
    "pass,\nrate, time left); --quiet: none.\n";

// The options as replay parameters, without stop flag and progress callback.
pcap::ReplayParams replay_params(const Args& args) {
    pcap::ReplayParams params;
    params.host_ip = net::resolve_ipv4(args.value("--to").value_or("127.0.0.1"));
    for (const auto& mapping : args.values("--port-map")) {
        const auto colon = mapping.find(':');
        if (colon == std::string::npos) {
            throw UsageError("--port-map expects ORIG:NEW, got '" + mapping + "'");
        }
        params.port_map[parse_port(mapping.substr(0, colon), "--port-map")] =
            parse_port(mapping.substr(colon + 1), "--port-map");
    }
    params.max_rate = args.flag("--max-rate");
    if (params.max_rate && args.value("--rate")) {
        throw UsageError("--rate and --max-rate exclude each other");
    }
    params.rate = args.number("--rate", 1.0);
    if (!(params.rate > 0.0)) throw UsageError("--rate must be > 0");
    params.loop = args.flag("--loop");
    const long long passes = args.integer("--passes", 0);
    if (passes < 0 || (passes > 0 && !params.loop)) {
        throw UsageError("--passes N (N >= 1) needs --loop");
    }
    params.max_passes = static_cast<std::uint64_t>(passes);
    params.max_duration_s = args.number("--duration", 0.0);
    if (params.max_duration_s < 0) throw UsageError("--duration must be >= 0");
    return params;
}

// Ctrl-C and SIGTERM end the replay through g_stop (async-signal-safe: an atomic store).
void install_stop_handlers() {
    g_stop.store(false);
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
}

// The progress line of the replay, called by replay_capture() on this thread.
struct ReplayProgress {
    ProgressLine* progress;
    double file_bytes;  // 0: no share shown
    bool loop;
    std::uint64_t max_passes;  // 0: until stopped

    void operator()(std::uint64_t pass, std::uint64_t sent, std::uint64_t bytes_read) const {
        // One pass: the share of the file; looping: the share of the passes asked for.
        double fraction = file_bytes > 0 ? static_cast<double>(bytes_read) / file_bytes : -1.0;
        if (loop) {
            fraction = max_passes > 0 && fraction >= 0 ? (static_cast<double>(pass) + fraction) /
                                                             static_cast<double>(max_passes)
                                                       : -1.0;
        }
        progress->update({loop ? "pass " + std::to_string(pass + 1) : "sending",
                          static_cast<double>(sent), 0, "datagrams", fraction, 0});
    }
};

void print_summary(const pcap::ReplaySummary& s, std::uint32_t host_ip) {
    std::printf("replay_target %s ipv4\n", net::ipv4_to_string(host_ip).c_str());
    std::printf("replay_datagrams_sent %llu datagrams\n",
                static_cast<unsigned long long>(s.datagrams_sent));
    std::printf("replay_bytes_sent %llu bytes\n", static_cast<unsigned long long>(s.bytes_sent));
    std::printf("replay_send_errors %llu datagrams\n",
                static_cast<unsigned long long>(s.send_errors));
    std::printf("replay_passes %llu passes\n", static_cast<unsigned long long>(s.passes));
    std::printf("replay_sources %zu sockets\n", s.source_sockets);
    std::printf("replay_duration %.6f s\n", s.duration_s);
    std::printf("replay_capture_span %.6f s\n", s.capture_span_s);
    std::printf("replay_rate %.1f datagrams/s\n", s.datagrams_per_s());
    std::printf("replay_throughput %.3f Mbit/s\n", s.megabits_per_s());
    std::printf("replay_records_read %llu records\n",
                static_cast<unsigned long long>(s.reader_stats.records));
    std::printf("replay_fragments_reassembled %llu datagrams\n",
                static_cast<unsigned long long>(s.reader_stats.reassembled));
    std::printf("replay_incomplete_dropped %llu datagrams\n",
                static_cast<unsigned long long>(s.reader_stats.dropped_incomplete));
    std::printf("replay_interrupted %d flag\n", s.stopped ? 1 : 0);
}

int run_replay(int argc, char** argv) {
    const Args args(argc, argv, {"--to", "--port-map", "--rate", "--passes", "--duration"},
                    {"--max-rate", "--loop", "--quiet"});
    if (args.help()) {
        std::printf("%s", kUsage);
        return 0;
    }
    if (args.positionals().size() != 1) {
        throw UsageError(
            "expects exactly one capture file or recording folder (see lidarfuse replay --help)");
    }
    const auto files = pcap::capture_files(args.positionals()[0]);
    pcap::ReplayParams params = replay_params(args);
    install_stop_handlers();
    params.stop = &g_stop;

    ProgressLine progress("replay", progress_wanted(args));
    params.on_progress = ReplayProgress{&progress, progress_file_bytes(args.positionals()[0]),
                                        params.loop, params.max_passes};
    const auto s = pcap::replay_capture(files, params);
    progress.finish();
    if (!s.warning.empty())
        std::fprintf(stderr, "lidarfuse replay: warning: %s\n", s.warning.c_str());
    if (s.send_errors > 0) {
        std::fprintf(
            stderr, "lidarfuse replay: %llu datagrams could not be sent (first error: %s)\n",
            static_cast<unsigned long long>(s.send_errors), std::strerror(s.first_send_errno));
    }
    print_summary(s, params.host_ip);
    return 0;
}

}  // namespace

LIDARFUSE_REGISTER_COMMAND("replay",
                           "send a capture's UDP datagrams to a host, at recorded timing or faster",
                           run_replay);

}  // namespace lidarfuse::tools
