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
#include <string>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/foxglove_schemas.hpp"
#include "daemon/pipeline.hpp"
#include "daemon/status_line.hpp"
#include "daemon/systemd_notify.hpp"
#include "drivers/build_info.hpp"
#include "drivers/process_env.hpp"

namespace {

const char* const kUsage =
    "usage: lidarfused --config STATION.yaml [--check] [--output-dir DIR]\n"
    "  --check        validate the config (and metadata files) and exit\n"
    "  --output-dir   override output.directory\n";

}  // namespace

int main(int argc, char** argv) {
    lidarfuse::drivers::ensure_passive_openmp(argv);
    std::string config_path, output_dir;
    bool check_only = false;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--help" || arg == "-h") {
            std::printf("%s", kUsage);
            return 0;
        } else if (arg == "--version") {
            std::printf("lidarfused %s\n", lidarfuse::drivers::version().c_str());
            return 0;
        } else if (arg == "--config" && i + 1 < argc) {
            config_path = argv[++i];
        } else if (arg == "--output-dir" && i + 1 < argc) {
            output_dir = argv[++i];
        } else if (arg == "--check") {
            check_only = true;
        } else {
            std::fprintf(stderr, "lidarfused: unexpected argument '%s'\n%s", arg.c_str(), kUsage);
            return 2;
        }
    }
    if (config_path.empty()) {
        std::fprintf(stderr, "lidarfused: --config is required\n%s", kUsage);
        return 2;
    }
    auto log = spdlog::default_logger()->clone("daemon");
    lidarfuse::daemon::DaemonConfig config;
    try {
        config = lidarfuse::daemon::load_daemon_config(config_path);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "lidarfused: %s\n", error.what());
        return 1;
    }
    if (!output_dir.empty()) config.output.directory = output_dir;
    spdlog::set_level(spdlog::level::from_str(config.log_level));

    // Block the signals before any thread exists, so every thread inherits the mask and the
    // main thread alone takes them with sigtimedwait.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);

    // A check binds the ports but records nothing (no recording folder is made): it only
    // says whether one could be.
    if (check_only && config.output.record.enabled) {
        const std::string problem = lidarfuse::daemon::record_directory_problem(
            lidarfuse::daemon::record_directory(config.output));
        if (!problem.empty()) {
            std::fprintf(stderr, "lidarfused: output.record.directory: %s\n", problem.c_str());
            return 1;
        }
        config.output.record.enabled = false;
    }
    std::unique_ptr<lidarfuse::daemon::Pipeline> pipeline;
    try {
        pipeline = std::make_unique<lidarfuse::daemon::Pipeline>(config);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "lidarfused: %s\n", error.what());
        return 1;
    }
    if (check_only) {
        std::size_t by_host = 0;
        for (const auto& s : config.station.sensors) by_host += s.enabled && s.hostname;
        std::printf("lidarfused: %s is valid (%zu sensors)%s\n", config_path.c_str(),
                    config.station.sensors.size(),
                    by_host == 0 ? ""
                                 : (" (" + std::to_string(by_host) +
                                    " named by hostname: their metadata is fetched when the daemon "
                                    "runs, not by --check)")
                                       .c_str());
        return 0;
    }
    lidarfuse::daemon::SystemdNotifier notifier;
    pipeline->start();
    std::string ports;
    for (auto p : pipeline->bound_ports()) ports += (ports.empty() ? "" : ",") + std::to_string(p);
    log->info("station {}: {} sensors, listening on UDP {}, output to {}", config.station.station,
              config.station.sensors.size(), ports, config.output.directory.string());
    if (config.output.record.enabled)
        log->info("recording every datagram to {}", pipeline->stats().record.folder);
    if (pipeline->dds_domain_id() >= 0) {
        log->info(
            "publishing on DDS domain {}: rt/tf, rt/diagnostics, rt/{}/{{points,poses}} in frame "
            "{}, "
            "stamped on the {} clock",
            pipeline->dds_domain_id(), config.output.dds.topic_namespace,
            config.output.dds.frame_id,
            config.output.stamp == lidarfuse::daemon::StampSource::kHost ? "host's" : "sensors'");
    }
    if (pipeline->foxglove_port() > 0) {
        std::string topics;
        for (const auto& c : lidarfuse::daemon::foxglove_channels(
                 config.output.dds.topic_namespace, config.output.dds.points_voxel_size_m > 0))
            topics += (topics.empty() ? "" : ", ") + c.topic;
        log->info("foxglove: live view on ws://{}:{} ({})", config.output.foxglove.bind_address,
                  pipeline->foxglove_port(), topics);
    }
    notifier.ready("listening on UDP " + ports);

    const auto watchdog_period = notifier.watchdog_period().value_or(std::chrono::seconds(5));
    auto last_report = std::chrono::steady_clock::now();
    while (true) {
        timespec timeout{0, 200'000'000};
        const int sig = sigtimedwait(&signals, nullptr, &timeout);
        if (sig == SIGTERM || sig == SIGINT) {
            log->info("signal {}: stopping", sig == SIGTERM ? "SIGTERM" : "SIGINT");
            notifier.stopping();
            break;
        }
        if (sig == SIGHUP) pipeline->request_reopen();
        const auto now = std::chrono::steady_clock::now();
        if (now - pipeline->heartbeat() < 2 * watchdog_period) notifier.watchdog();
        if (now - last_report >= std::chrono::seconds(1)) {
            last_report = now;
            const auto st = pipeline->stats();
            notifier.status(lidarfuse::daemon::status_line(st));
            for (const auto& s : st.sensors) {
                log->debug("{}: {} packets {} scans {} bad {} late {} completeness {:.3f} track {}",
                           s.name, lidarfuse::daemon::to_string(s.state), s.packets, s.scans,
                           s.bad_packets, s.late_packets, s.last_completeness, s.track_state);
            }
        }
    }
    pipeline->stop();
    const auto st = pipeline->stats();
    log->info("stopped: {}", lidarfuse::daemon::status_line(st));
    if (st.record.enabled) {
        log->info("recorded {} datagrams ({:.1f} MB) in {} files to {}{}", st.record.datagrams,
                  static_cast<double>(st.record.bytes) / 1e6, st.record.files, st.record.folder,
                  st.record.problem().empty() ? "" : "; " + st.record.problem());
    }
    if (pipeline->dds_domain_id() >= 0) {
        log->info("DDS: {} samples written, {} writes failed ({} timed out)",
                  st.dds_samples_written, st.dds_write_failures, st.dds_write_timeouts);
    }
    if (st.foxglove.enabled) {
        log->info(
            "foxglove: {} connections ({} refused), {} messages sent, {} dropped for slow "
            "clients, {} before any client",
            st.foxglove.connections, st.foxglove.refused, st.foxglove.sent, st.foxglove.dropped,
            st.foxglove.queue_drops);
    }
    return 0;
}
