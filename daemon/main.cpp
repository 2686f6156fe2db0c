// lidarfused: the station daemon. `lidarfused --config /etc/lidarfuse/station.yaml`
//
// Start-up: the whole config is validated (every problem listed, exit 1) and every socket
// bound before any thread starts; then READY=1 goes to systemd. Signals are taken
// synchronously by the main thread (sigtimedwait), never in a handler:
//   SIGTERM, SIGINT  drain and exit 0 (threads joined, files closed, within a second)
//   SIGHUP           re-open poses.csv (after logrotate moved it) and rewrite
//                    extrinsics.yaml; the config itself is not reloaded (restart for that)
// WATCHDOG=1 is sent only while the fusion thread's heartbeat is fresh, so a stuck fusion
// thread gets the service restarted by systemd.
#include <signal.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/foxglove_schemas.hpp"
#include "daemon/pipeline.hpp"
#include "daemon/status_line.hpp"
#include "daemon/systemd_notify.hpp"
#include "drivers/build_info.hpp"
#include "drivers/process_env.hpp"

namespace lidarfuse::daemon {
namespace {

const char* const kUsage =
    "usage: lidarfused --config STATION.yaml [--check] [--output-dir DIR]\n"
    "  --check        validate the config (and metadata files) and exit\n"
    "  --output-dir   override output.directory\n";

struct Arguments {
    std::string config_path, output_dir;
    bool check_only = false;
};

// The exit code when the daemon must not run (help, version, bad arguments).
std::optional<int> parse_arguments(int argc, char** argv, Arguments* args) {
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--help" || arg == "-h") {
            std::printf("%s", kUsage);
            return 0;
        } else if (arg == "--version") {
            std::printf("lidarfused %s\n", drivers::version().c_str());
            return 0;
        } else if (arg == "--config" && i + 1 < argc) {
            args->config_path = argv[++i];
        } else if (arg == "--output-dir" && i + 1 < argc) {
            args->output_dir = argv[++i];
        } else if (arg == "--check") {
            args->check_only = true;
        } else {
            std::fprintf(stderr, "lidarfused: unexpected argument '%s'\n%s", arg.c_str(), kUsage);
            return 2;
        }
    }
    if (args->config_path.empty()) {
        std::fprintf(stderr, "lidarfused: --config is required\n%s", kUsage);
        return 2;
    }
    return std::nullopt;
}

// The config with --output-dir applied, and the log level set; false (said) when invalid.
bool load_config(const Arguments& args, DaemonConfig* config) {
    try {
        *config = load_daemon_config(args.config_path);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "lidarfused: %s\n", error.what());
        return false;
    }
    if (!args.output_dir.empty()) config->output.directory = args.output_dir;
    spdlog::set_level(spdlog::level::from_str(config->log_level));
    return true;
}

// Blocks the signals before any thread exists, so every thread inherits the mask and the
// main thread alone takes them with sigtimedwait.
sigset_t block_signals() {
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    return signals;
}

// A check binds the ports but records nothing (no recording folder is made): it only says
// whether one could be. False (said) when it could not.
bool check_without_recording(DaemonConfig* config) {
    if (!config->output.record.enabled) return true;
    const std::string problem = record_directory_problem(record_directory(config->output));
    if (!problem.empty()) {
        std::fprintf(stderr, "lidarfused: output.record.directory: %s\n", problem.c_str());
        return false;
    }
    config->output.record.enabled = false;
    return true;
}

void print_check_passed(const std::string& config_path, const DaemonConfig& config) {
    std::size_t by_host = 0;
    for (const auto& s : config.station.sensors) by_host += s.enabled && s.hostname;
    std::printf("lidarfused: %s is valid (%zu sensors)%s\n", config_path.c_str(),
                config.station.sensors.size(),
                by_host == 0 ? ""
                             : (" (" + std::to_string(by_host) +
                                " named by hostname: their metadata is fetched when the daemon "
                                "runs, not by --check)")
                                   .c_str());
}

// What runs where: the ports (returned, "7502,7503"), DDS, the live view, the recording.
std::string log_started(spdlog::logger& log, const Pipeline& pipeline, const DaemonConfig& config) {
    std::string ports;
    for (auto p : pipeline.bound_ports()) ports += (ports.empty() ? "" : ",") + std::to_string(p);
    if (ports.empty()) ports = "(no port: every sensor is a DDS source)";
    log.info("station {}: {} sensors, listening on UDP {}, output to {}", config.station.station,
             config.station.sensors.size(), ports, config.output.directory.string());
    for (const auto& s : config.station.sensors) {
        if (s.enabled && s.dds) {
            log.info("sensor \"{}\": clouds from DDS topic {} in domain {}", s.name, s.dds->topic,
                     s.dds->domain_id);
        }
    }
    if (config.output.record.enabled)
        log.info("recording every datagram to {}", pipeline.stats().record.folder);
    if (pipeline.dds_domain_id() >= 0) {
        log.info(
            "publishing on DDS domain {}: rt/tf, rt/diagnostics, rt/{}/{{points,poses}} in frame "
            "{}, "
            "stamped on the {} clock",
            pipeline.dds_domain_id(), config.output.dds.topic_namespace, config.output.dds.frame_id,
            config.output.stamp == StampSource::kHost ? "host's" : "sensors'");
    }
    if (pipeline.foxglove_port() > 0) {
        std::string topics;
        for (const auto& c : foxglove_channels(config.output.dds.topic_namespace,
                                               config.output.dds.points_voxel_size_m > 0))
            topics += (topics.empty() ? "" : ", ") + c.topic;
        log.info("foxglove: live view on ws://{}:{} ({})", config.output.foxglove.bind_address,
                 pipeline.foxglove_port(), topics);
    }
    return ports;
}

// A sensor's change of state, once: to a degraded state at warning, back to OK at info.
// `previous` holds each sensor's state at the last report (empty before the first, whose
// states are taken as they are).
void log_state_changes(spdlog::logger& log, const PipelineStats& st,
                       std::vector<SensorState>* previous) {
    if (previous->size() != st.sensors.size()) {
        for (const auto& s : st.sensors) previous->push_back(s.state);
        return;
    }
    for (std::size_t i = 0; i < st.sensors.size(); ++i) {
        const SensorState was = (*previous)[i], now = st.sensors[i].state;
        if (now == was) continue;
        (*previous)[i] = now;
        if (now == SensorState::kOk) {
            log.info("sensor \"{}\": OK (was {})", st.sensors[i].name, to_string(was));
        } else {
            log.warn("sensor \"{}\": {} (was {})", st.sensors[i].name, to_string(now),
                     to_string(was));
        }
    }
}

// Once a second: systemd's STATUS= line, every sensor's change of state, and every sensor's
// counters (debug).
void report(spdlog::logger& log, const Pipeline& pipeline, const SystemdNotifier& notifier,
            std::vector<SensorState>* states) {
    const auto st = pipeline.stats();
    notifier.status(status_line(st));
    log_state_changes(log, st, states);
    for (const auto& s : st.sensors) {
        log.debug("{}: {} packets {} scans {} bad {} late {} completeness {:.3f} track {}", s.name,
                  to_string(s.state), s.packets, s.scans, s.bad_packets, s.late_packets,
                  s.last_completeness, s.track_state);
    }
}

// Until SIGTERM or SIGINT: SIGHUP re-opens the output files; the watchdog is fed while the
// fusion thread's heartbeat is fresh.
void run_until_stopped(const sigset_t& signals, spdlog::logger& log, Pipeline& pipeline,
                       const SystemdNotifier& notifier) {
    const auto watchdog_period = notifier.watchdog_period().value_or(std::chrono::seconds(5));
    auto last_report = std::chrono::steady_clock::now();
    std::vector<SensorState> states;
    while (true) {
        timespec timeout{0, 200'000'000};
        const int sig = sigtimedwait(&signals, nullptr, &timeout);
        if (sig == SIGTERM || sig == SIGINT) {
            log.info("signal {}: stopping", sig == SIGTERM ? "SIGTERM" : "SIGINT");
            notifier.stopping();
            return;
        }
        if (sig == SIGHUP) pipeline.request_reopen();
        const auto now = std::chrono::steady_clock::now();
        if (now - pipeline.heartbeat() < 2 * watchdog_period) notifier.watchdog();
        if (now - last_report >= std::chrono::seconds(1)) {
            last_report = now;
            report(log, pipeline, notifier, &states);
        }
    }
}

// How the run ended: the status line, and what the recorder, DDS and the live view did.
void log_stopped(spdlog::logger& log, const Pipeline& pipeline) {
    const auto st = pipeline.stats();
    log.info("stopped: {}", status_line(st));
    if (st.record.enabled) {
        log.info("recorded {} datagrams ({:.1f} MB) in {} files to {}{}", st.record.datagrams,
                 static_cast<double>(st.record.bytes) / 1e6, st.record.files, st.record.folder,
                 st.record.problem().empty() ? "" : "; " + st.record.problem());
    }
    if (pipeline.dds_domain_id() >= 0) {
        log.info("DDS: {} samples written, {} writes failed ({} timed out)", st.dds_samples_written,
                 st.dds_write_failures, st.dds_write_timeouts);
    }
    if (st.foxglove.enabled) {
        log.info(
            "foxglove: {} connections ({} refused), {} messages sent, {} dropped for slow "
            "clients, {} before any client",
            st.foxglove.connections, st.foxglove.refused, st.foxglove.sent, st.foxglove.dropped,
            st.foxglove.queue_drops);
    }
}

int run(int argc, char** argv) {
    Arguments args;
    if (const auto exit_code = parse_arguments(argc, argv, &args)) return *exit_code;
    auto log = spdlog::default_logger()->clone("daemon");
    DaemonConfig config;
    if (!load_config(args, &config)) return 1;
    const sigset_t signals = block_signals();
    if (args.check_only && !check_without_recording(&config)) return 1;
    std::unique_ptr<Pipeline> pipeline;
    try {
        pipeline = std::make_unique<Pipeline>(config);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "lidarfused: %s\n", error.what());
        return 1;
    }
    if (args.check_only) {
        print_check_passed(args.config_path, config);
        return 0;
    }
    SystemdNotifier notifier;
    pipeline->start();
    notifier.ready("listening on UDP " + log_started(*log, *pipeline, config));
    run_until_stopped(signals, *log, *pipeline, notifier);
    pipeline->stop();
    log_stopped(*log, *pipeline);
    return 0;
}

}  // namespace
}  // namespace lidarfuse::daemon

int main(int argc, char** argv) {
    lidarfuse::drivers::ensure_passive_openmp(argv);
    lidarfuse::drivers::keep_frame_buffers_in_heap();
    return lidarfuse::daemon::run(argc, argv);
}
