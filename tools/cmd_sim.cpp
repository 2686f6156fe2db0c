// `lidarfuse sim --scenario {curve|straight|intersection} --out DIR ...`: virtual OS1-64
// sensors in a synthetic roadside scene; writes capture.pcap, <sensor>.json,
// ground_truth.csv and station.yaml (drivers/sim/sim_outputs.hpp).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>

#include "core/common/stopwatch.hpp"
#include "drivers/net/ipv4_address.hpp"
#include "drivers/sim/live_sink.hpp"
#include "drivers/sim/sim_http_server.hpp"
#include "drivers/sim/sim_outputs.hpp"
#include "drivers/sim/simulator.hpp"
#include "tools/args.hpp"
#include "tools/command.hpp"
#include "tools/progress.hpp"

namespace lidarfuse::tools {

namespace {

constexpr const char* kUsage =
    "usage: lidarfuse sim --scenario {curve|straight|intersection} --out DIR\n"
    "                     [--sensors 4 | --stations K [--sensors-per-station 4]\n"
    "                      [--station-spacing-m 80]] [--seconds 10] [--mode 1024x20]\n"
    "                     [--profile LEGACY|RNG19_RFL8_SIG16_NIR16|RNG15_RFL8_NIR8]\n"
    "                     [--seed 1] [--no-motion] [--no-traffic] [--noise-sigma-m 0.0333]\n"
    "                     [--whole-datagrams] [--threads N] [--fault SPEC]...\n"
    "                     [--live --to HOST[:PORT] [--http ADDRESS[:PORT]]] [--quiet]\n"
    "Virtual Ouster OS1-64 sensors (6 m poles, tilted 17 deg down, swaying as inverted\n"
    "spherical pendulums) in a synthetic street with traffic. Writes into DIR:\n"
    "  capture.pcap      all sensors' lidar packets; sensor k sends from 169.254.10.(11+k)\n"
    "                    to port 7502+2k; IPv4 fragments at MTU 1500 (--whole-datagrams: not)\n"
    "  lidarK.json       nested Ouster metadata of each sensor\n"
    "  ground_truth.csv  frame,sensor,t_ns,x,y,z,qw,qx,qy,qz: T_world_sensor at each frame's\n"
    "                    timestamp (column 0), world z up, road surface at z = 0\n"
    "  station.yaml      station config for calibrate/fuse/lidarfused (no poses)\n"
    "  With --stations K (straight or curve): K stations along the road, their middles\n"
    "  --station-spacing-m apart, each laid out as one station is; DIR/station0 ..\n"
    "  DIR/station<K-1> each hold the files above for that station's sensors (named\n"
    "  lidar0.., sending from .11.. to 7502.. as a station simulated alone); all ground\n"
    "  truth is in the one world frame of the road\n"
    "Options:\n"
    "  --no-motion        poles do not sway\n"
    "  --no-traffic       no road users\n"
    "  --noise-sigma-m X  range noise sigma in metres (default 0.1/3; 0 = none)\n"
    "  --threads N        render threads (default: all cores; output does not depend on it)\n"
    "  --live --to HOST[:PORT]  send the packets over UDP in real time to HOST instead of\n"
    "                     writing capture.pcap (sensor k to PORT+2k, default PORT 7502);\n"
    "                     DIR still gets the metadata, station.yaml and ground_truth.csv\n"
    "  --http ADDRESS[:PORT]  with --live: sensor k also serves Ouster's HTTP API (metadata,\n"
    "                     configuration) on ADDRESS+k, PORT (default 80), e.g. 127.0.1.1:8080\n"
    "                     for 127.0.1.1, 127.0.1.2, ...; a POST to /api/v1/sensor/config moves\n"
    "                     where that sensor sends\n"
    "  --quiet            no progress line (on a terminal, stderr shows frames done, rate\n"
    "                     and time left)\n"
    "Faults (--fault SPEC, repeatable; SENSOR = lidar0, lidar1, ...):\n"
    "  drop:SHARE[:SENSOR]          drop that share (0..1) of packets\n"
    "  reorder:SHARE[:SENSOR]       swap that share of packets with the sensor's next one\n"
    "  duplicate:SHARE[:SENSOR]     send that share of packets twice\n"
    "  truncate:SHARE[:SENSOR]      cut that share of packets to a random shorter length\n"
    "  init-id:SENSOR:AT_S          new init_id from AT_S seconds on (non-LEGACY headers)\n"
    "  silence:SENSOR:FROM_S:DUR_S  the sensor sends nothing for DUR_S seconds\n"
    "  clock-offset:SENSOR:OFFSET_S add OFFSET_S to the sensor's packet timestamps\n"
    "Prints `name value unit` lines: rays, rays_per_s, realtime_ratio.\n";

// --sensors, or --stations with --sensors-per-station and --station-spacing-m.
void parse_stations(const Args& args, sim::SimParams* p) {
    const bool several = args.value("--stations") || args.value("--sensors-per-station") ||
                         args.value("--station-spacing-m");
    if (several && args.value("--sensors")) {
        throw UsageError(
            "--sensors counts the sensors of one station: with --stations use "
            "--sensors-per-station");
    }
    if (!several) {
        p->sensors = static_cast<int>(args.integer("--sensors", 4));
        return;
    }
    const long long stations = args.integer("--stations", 1);
    const long long per_station = args.integer("--sensors-per-station", 4);
    if (stations < 1 || per_station < 1 || stations * per_station > 16) {
        throw UsageError(
            "--stations and --sensors-per-station must be at least 1, with at "
            "most 16 sensors in all");
    }
    p->stations = static_cast<int>(stations);
    p->sensors = static_cast<int>(stations * per_station);
    p->station_spacing_m = args.number("--station-spacing-m", 80.0);
    if (!(p->station_spacing_m >= 10.0) || p->station_spacing_m > 1000.0) {
        throw UsageError("--station-spacing-m must be in [10, 1000] m");
    }
    if (p->stations > 1 && (args.value("--fault") || args.flag("--live"))) {
        throw UsageError("--fault and --live take one station: not with --stations above 1");
    }
}

sim::SimParams parse_params(const Args& args) {
    sim::SimParams p;
    const std::string scenario = args.required("--scenario");
    const auto s = sim::scenario_from_string(scenario);
    if (!s)
        throw UsageError("--scenario must be curve, straight or intersection, got '" + scenario +
                         "'");
    p.scenario = *s;
    parse_stations(args, &p);
    p.seconds = args.number("--seconds", 10.0);
    const std::string mode = args.value("--mode").value_or("1024x20");
    const auto wf = ouster::parse_lidar_mode(mode);
    if (!wf) throw UsageError("--mode: not an Ouster lidar mode: '" + mode + "'");
    p.columns_per_frame = (*wf)[0];
    p.frames_per_second = (*wf)[1];
    const std::string profile = args.value("--profile").value_or("LEGACY");
    const auto pr = ouster::udp_profile_lidar_from_string(profile);
    if (!pr) throw UsageError("--profile: unknown profile '" + profile + "'");
    p.profile = *pr;
    const long long seed = args.integer("--seed", 1);
    if (seed < 0) throw UsageError("--seed must not be negative");
    p.seed = static_cast<std::uint64_t>(seed);
    p.motion = !args.flag("--no-motion");
    p.traffic = !args.flag("--no-traffic");
    p.sensor.noise_sigma_m = args.number("--noise-sigma-m", 0.1 / 3.0);
    p.threads = static_cast<int>(args.integer("--threads", 0));
    for (const auto& spec : args.values("--fault")) {
        try {
            sim::parse_fault(spec, p.sensors, &p.faults);
        } catch (const std::invalid_argument& e) {
            throw UsageError(e.what());
        }
    }
    return p;
}

// "HOST:PORT" -> HOST, and PORT (checked to be in min_port..65535); nullopt without ':'.
std::optional<int> split_port(std::string* host, const char* option, int min_port) {
    const auto colon = host->rfind(':');
    if (colon == std::string::npos) return std::nullopt;
    const long long port = std::atoll(host->c_str() + colon + 1);
    if (port < min_port || port > 65535)
        throw UsageError(std::string(option) + ": bad port in '" + *host + "'");
    host->resize(colon);
    return static_cast<int>(port);
}

// --live: the packets over UDP at the capture's pace, and with --http each sensor's API.
sim::SimStats run_live(sim::Simulator& simulator, const std::string& host,
                       const std::optional<std::string>& http) {
    sim::LiveRoutes routes(simulator, net::resolve_ipv4(host));
    std::unique_ptr<sim::SimHttpServer> server;
    if (http) {
        std::string address = *http;
        sim::SimHttpParams hp;
        if (const auto port = split_port(&address, "--http", 1)) hp.port = *port;
        try {
            hp.first_ip = net::parse_ipv4(address);
        } catch (const std::invalid_argument& e) {
            throw UsageError(std::string("--http: ") + e.what());
        }
        server = std::make_unique<sim::SimHttpServer>(simulator, &routes, hp);
    }
    sim::LiveSink sink(&routes);
    const sim::SimStats stats = simulator.run(sink);
    std::printf("sim_live_sent %llu datagrams\n", static_cast<unsigned long long>(sink.sent()));
    std::printf("sim_live_late %llu datagrams\n", static_cast<unsigned long long>(sink.late()));
    std::printf("sim_live_send_errors %llu datagrams\n",
                static_cast<unsigned long long>(sink.errors()));
    std::printf("sim_live_held_back %llu datagrams\n",
                static_cast<unsigned long long>(sink.held_back()));
    if (server) {
        std::printf("sim_http_requests %llu requests\n",
                    static_cast<unsigned long long>(server->requests()));
    }
    return stats;
}

int run_sim(int argc, char** argv) {
    const Args args(argc, argv,
                    {"--scenario", "--out", "--sensors", "--stations", "--sensors-per-station",
                     "--station-spacing-m", "--seconds", "--mode", "--profile", "--seed",
                     "--noise-sigma-m", "--threads", "--fault", "--to", "--http"},
                    {"--no-motion", "--no-traffic", "--whole-datagrams", "--live", "--quiet"});
    if (args.help()) {
        std::printf("%s", kUsage);
        return 0;
    }
    sim::SimParams params = parse_params(args);
    const std::string out = args.required("--out");
    std::string live_host;
    if (args.flag("--live")) {
        live_host = args.required("--to");
        if (const auto port = split_port(&live_host, "--to", 1024)) {
            params.first_lidar_port = static_cast<std::uint16_t>(*port);
        }
    } else if (args.value("--to") || args.value("--http")) {
        throw UsageError("--to and --http need --live");
    }
    const core::Stopwatch wall_time;
    sim::Simulator simulator(params);
    ProgressLine progress("sim", progress_wanted(args));
    simulator.set_on_frame([&](int done, int total) {
        progress.update({live_host.empty() ? "rendering" : "sending live",
                         static_cast<double>(done), static_cast<double>(total), "frames",
                         static_cast<double>(done) / static_cast<double>(std::max(1, total)), 0});
    });
    sim::OutputOptions options;
    options.fragment = !args.flag("--whole-datagrams");
    sim::SimStats stats;
    if (!live_host.empty()) {
        sim::write_description(simulator, out, options);
        stats = run_live(simulator, live_host, args.value("--http"));
    } else {
        stats = sim::write_simulation(simulator, out, options);
    }
    progress.finish();
    const double wall = wall_time.seconds();
    std::printf("sim_rays %llu rays\n", static_cast<unsigned long long>(stats.rays));
    std::printf("sim_returns %llu points\n", static_cast<unsigned long long>(stats.returns));
    std::printf("sim_datagrams %llu datagrams\n",
                static_cast<unsigned long long>(stats.datagrams_sent));
    std::printf("sim_rays_per_s %.0f rays/s\n",
                static_cast<double>(stats.rays) / stats.render_wall_s);
    std::printf("sim_realtime_ratio %.2f x\n", params.seconds / wall);
    return 0;
}

}  // namespace

LIDARFUSE_REGISTER_COMMAND("sim",
                           "simulate OS1-64 sensors in a street: pcap, metadata, ground truth",
                           run_sim);

}  // namespace lidarfuse::tools
