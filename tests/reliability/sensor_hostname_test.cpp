// Sensors named by hostname (station.yaml sensors[].hostname), end to end against a real
// HTTP peer: `lidarfuse sim --live --http` serves each simulated sensor's HTTP API on a
// loopback address of its own, and the daemon's Pipeline fetches, configures, streams and
// follows a reboot (daemon/metadata_fetcher.hpp). Also: a sensor that never answers, and
// metadata that disagrees with the packets (an HTTP server of the test's own).
#include <gtest/gtest.h>

#include <map>
#include <mutex>

#include "daemon/dds_messages.hpp"
#include "daemon/status_line.hpp"
#include "drivers/net/ipv4_address.hpp"
#include "drivers/ouster/metadata.hpp"
#include "tests/reliability/station_fixture.hpp"
// Last: it pulls in <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace lidarfuse::reliability {
namespace {

using daemon::SensorState;
using namespace std::chrono_literals;

// 127.a.b.1, .2, ...: the simulated sensors' addresses, private to this test process
// (all of 127/8 is loopback on Linux).
std::uint32_t first_sensor_ip() {
    const auto pid = static_cast<std::uint32_t>(::getpid());
    return (127u << 24) | ((100 + pid % 100) << 16) | (((pid / 100) % 250) << 8) | 1u;
}
constexpr int kHttpPort = 8080;

// The simulator's station.yaml, its sensors named by hostname instead of metadata files.
daemon::DaemonConfig hostname_config(const std::filesystem::path& sim_dir,
                                     const std::filesystem::path& out_dir, int slot,
                                     bool configure) {
    auto config = station_config(sim_dir, out_dir, slot);
    for (std::size_t k = 0; k < config.station.sensors.size(); ++k) {
        auto& s = config.station.sensors[k];
        s.metadata.clear();
        s.hostname = net::ipv4_to_string(first_sensor_ip() + static_cast<std::uint32_t>(k));
        s.http_port = kHttpPort;
        s.configure.enabled = configure;
    }
    return config;
}

// Polls the pipeline's stats until `condition` holds (at most `timeout`).
bool stats_until(const daemon::Pipeline& pipeline,
                 const std::function<bool(const daemon::PipelineStats&)>& condition,
                 std::chrono::milliseconds timeout) {
    return wait_for([&] { return condition(pipeline.stats()); }, timeout);
}

TEST(SensorHostname, FetchesConfiguresStreamsAndFollowsARebootWithoutARestart) {
    test::TempDir sim("hostname-sim"), out("hostname-out");
    const int slot = 0;
    // The sensors first send to ports nobody listens on: only the daemon's configuration
    // (udp_port_lidar = its sensor's udp_port) brings their data. lidar1 reboots at 5 s.
    const std::uint16_t nowhere = static_cast<std::uint16_t>(base_port(slot) + 4);
    BackgroundCommand sensors(
        test::tool_path() +
        " sim --scenario straight --sensors 2 --seconds 9 --mode 512x20"
        " --profile RNG19_RFL8_SIG16_NIR16 --no-traffic --whole-datagrams --threads 1 --seed 3"
        " --fault init-id:lidar1:5 --live --to 127.0.0.1:" +
        std::to_string(nowhere) + " --http " + net::ipv4_to_string(first_sensor_ip()) + ":" +
        std::to_string(kHttpPort) + " --quiet --out " + sim.path().string());
    ASSERT_TRUE(wait_for([&] { return std::filesystem::exists(sim.path() / "station.yaml"); }, 60s))
        << "the simulator wrote no station.yaml";
    std::this_thread::sleep_for(100ms);  // written before the simulator starts sending

    auto config = hostname_config(sim.path(), out.path(), slot, true);
    config.output.record.enabled = true;
    config.output.record.directory = out.path() / "recordings";
    daemon::Pipeline pipeline(config);
    pipeline.start();
    const auto both_fused = [](const daemon::PipelineStats& st) {
        return st.frames_fused > 0 && st.sensors[0].state == SensorState::kOk &&
               st.sensors[1].state == SensorState::kOk;
    };
    // Generous bounds: they end as soon as the state is reached (sanitizer builds render
    // the simulation slower than real time).
    EXPECT_TRUE(stats_until(pipeline, both_fused, 60s));
    const auto rebooted = [](const daemon::PipelineStats& st) {
        return st.sensors[1].metadata.changes >= 1 && st.sensors[1].state == SensorState::kOk;
    };
    EXPECT_TRUE(stats_until(pipeline, rebooted, 60s));
    const std::uint64_t scans_after_reboot = pipeline.stats().sensors[1].scans;
    EXPECT_TRUE(stats_until(
        pipeline, [&](const auto& st) { return st.sensors[1].scans > scans_after_reboot + 10; },
        30s))
        << "lidar1 was not fused again after its reboot";
    ASSERT_EQ(sensors.join(), 0) << sensors.output();
    const auto st = pipeline.stats();
    pipeline.stop();

    for (int k = 0; k < 2; ++k) {
        SCOPED_TRACE("lidar" + std::to_string(k));
        const auto& m = st.sensors[static_cast<std::size_t>(k)].metadata;
        EXPECT_EQ(m.configured, 1u);  // once: the sensor kept its configuration afterwards
        EXPECT_EQ(m.endpoint, "/api/v1/sensor/metadata");
        EXPECT_EQ(m.source,
                  "http://" +
                      net::ipv4_to_string(first_sensor_ip() + static_cast<std::uint32_t>(k)) + ":" +
                      std::to_string(kHttpPort));
        EXPECT_TRUE(m.last_error.empty()) << m.last_error;
    }
    EXPECT_EQ(st.sensors[0].metadata.changes, 0u);
    EXPECT_EQ(st.sensors[1].metadata.changes, 1u);
    // The copies in the output folder: lidar0 as the simulator wrote it, lidar1 after its
    // reboot (another init_id than the simulator's file, same sensor).
    const auto simulated0 = ouster::load_metadata(sim.path() / "lidar0.json");
    const auto simulated1 = ouster::load_metadata(sim.path() / "lidar1.json");
    const auto kept0 = ouster::load_metadata(out.path() / "lidar0.json");
    const auto kept1 = ouster::load_metadata(out.path() / "lidar1.json");
    EXPECT_EQ(kept0.prod_sn, simulated0.prod_sn);
    EXPECT_EQ(kept0.init_id, simulated0.init_id);
    EXPECT_EQ(kept0.udp_port_lidar, base_port(slot));  // as configured by the daemon
    EXPECT_EQ(kept1.prod_sn, simulated1.prod_sn);
    EXPECT_NE(kept1.init_id, simulated1.init_id);
    EXPECT_EQ(kept1.lidar_mode, "512x20");
    // The recording keeps both versions of lidar1's metadata: the later one from its reboot on.
    const std::filesystem::path recorded = st.record.folder;
    EXPECT_EQ(ouster::load_metadata(recorded / "metadata" / "lidar0.json").init_id, kept0.init_id);
    EXPECT_EQ(ouster::load_metadata(recorded / "metadata" / "lidar1.json").init_id,
              simulated1.init_id);
    std::vector<std::filesystem::path> later;
    for (const auto& e : std::filesystem::directory_iterator(recorded / "metadata")) {
        const std::string name = e.path().filename().string();
        if (name.rfind("lidar1.", 0) == 0 && name != "lidar1.json") later.push_back(e.path());
    }
    ASSERT_EQ(later.size(), 1u);
    EXPECT_EQ(ouster::load_metadata(later.front()).init_id, kept1.init_id);
    // The simulator was asked, and held its data back while re-initialising.
    EXPECT_GE(test::figure(sensors.output(), "sim_http_requests").value_or(0), 4.0);
    EXPECT_GT(test::figure(sensors.output(), "sim_live_held_back").value_or(0), 0.0);
}

TEST(SensorHostname, AnUnreachableSensorIsRetriedAndReportedWhileTheOtherFuses) {
    test::TempDir sim("hostname-away-sim"), out("hostname-away-out");
    simulate(sim.path(), 4.0, {});
    const int slot = 1;
    auto config = station_config(sim.path(), out.path(), slot);
    auto& away = config.station.sensors[1];
    away.metadata.clear();
    away.hostname = net::ipv4_to_string(first_sensor_ip() + 200);  // nothing listens there
    away.http_port = kHttpPort;

    daemon::Pipeline pipeline(config);
    pipeline.start();
    BackgroundReplay replay(sim.path() / "capture.pcap", "--to 127.0.0.1" + port_map(slot, 2));
    ASSERT_EQ(replay.join(), 0) << replay.output();
    const auto st = pipeline.stats();
    pipeline.stop();

    EXPECT_GT(st.sensors[0].scans, 40u);
    EXPECT_EQ(st.sensors[1].state, SensorState::kNoMetadata);
    EXPECT_EQ(st.sensors[1].scans, 0u);
    // Back-off 0.5, 1, 2 s: at least three attempts in the 4 s replay, never one per poll.
    EXPECT_GE(st.sensors[1].metadata.failures, 3u);
    EXPECT_LE(st.sensors[1].metadata.failures, 8u);
    EXPECT_NE(st.sensors[1].metadata.last_error.find(*away.hostname + ":8080"), std::string::npos)
        << st.sensors[1].metadata.last_error;
    EXPECT_GT(st.unassigned_datagrams, 0u);  // its packets: nobody can read them yet
    daemon::DiagnosticsBuilder diagnostics({"test", "map", {"lidar0", "lidar1"}, 0});
    const auto& array = diagnostics.build(st, 0);
    ASSERT_GE(array.status._length, 2u);
    const auto& status = array.status._buffer[1];
    EXPECT_EQ(status.level, 2);  // ERROR
    EXPECT_EQ(
        std::string(status.message).rfind("NO_METADATA: " + st.sensors[1].metadata.last_error, 0),
        0u)
        << status.message;
    std::map<std::string, std::string> values;
    for (std::uint32_t v = 0; v < status.values._length; ++v)
        values[status.values._buffer[v].key] = status.values._buffer[v].value;
    EXPECT_EQ(values["state"], "NO_METADATA");
    EXPECT_EQ(values["metadata_source"], "http://" + *away.hostname + ":8080");
    EXPECT_EQ(values["metadata_fetch_failures"], std::to_string(st.sensors[1].metadata.failures));
    EXPECT_EQ(values["metadata_last_error"], st.sensors[1].metadata.last_error);
    const std::string line = daemon::sensors_summary(st.sensors);
    EXPECT_NE(line.find("1 NO_METADATA: " + st.sensors[1].metadata.last_error + " (lidar1)"),
              std::string::npos)
        << line;
}

// An HTTP peer of the test's own serving a document the test can swap.
class MetadataServer {
public:
    explicit MetadataServer(std::uint32_t ip) {
        server_.Get("/api/v1/sensor/metadata",
                    [this](const httplib::Request&, httplib::Response& res) {
                        std::lock_guard<std::mutex> lock(mutex_);
                        res.set_content(document_, "application/json");
                    });
        EXPECT_TRUE(server_.bind_to_port(net::ipv4_to_string(ip).c_str(), kHttpPort));
        thread_ = std::thread([this] { server_.listen_after_bind(); });
        while (!server_.is_running()) std::this_thread::sleep_for(1ms);
    }
    ~MetadataServer() {
        server_.stop();
        thread_.join();
    }
    void serve(const std::string& document) {
        std::lock_guard<std::mutex> lock(mutex_);
        document_ = document;
    }

private:
    httplib::Server server_;
    std::mutex mutex_;
    std::string document_;
    std::thread thread_;
};

TEST(SensorHostname, MetadataOfAnotherModeIsFetchedAgainUntilItExplainsThePackets) {
    test::TempDir sim("hostname-mode-sim"), other("hostname-mode-1024"), out("hostname-mode-out");
    simulate(sim.path(), 7.0, {});
    simulate(other.path(), 0.2, {}, 2, "1024x20");
    const int slot = 2;
    auto config = station_config(sim.path(), out.path(), slot);
    auto& s1 = config.station.sensors[1];
    s1.metadata.clear();
    s1.hostname = net::ipv4_to_string(first_sensor_ip() + 100);
    s1.http_port = kHttpPort;
    MetadataServer server(first_sensor_ip() + 100);
    // lidar1's own serial and init_id, but 1024x20 where its packets are 512x20.
    auto wrong = ouster::load_metadata(other.path() / "lidar1.json");
    const auto right = ouster::load_metadata(sim.path() / "lidar1.json");
    wrong.prod_sn = right.prod_sn;
    wrong.init_id = right.init_id;
    server.serve(ouster::to_nested_json(wrong));

    daemon::Pipeline pipeline(config);
    pipeline.start();
    BackgroundReplay replay(sim.path() / "capture.pcap", "--to 127.0.0.1" + port_map(slot, 2));
    EXPECT_TRUE(stats_until(
        pipeline,
        [](const auto& st) {
            return st.sensors[1].state == SensorState::kModeMismatch &&
                   st.sensors[1].metadata.failures >= 1;
        },
        30s));
    const auto mismatched = pipeline.stats().sensors[1];
    server.serve(ouster::to_nested_json(right));  // the sensor's metadata is right again
    EXPECT_TRUE(stats_until(
        pipeline,
        [](const auto& st) {
            return st.sensors[1].state == SensorState::kOk && st.sensors[1].metadata.changes == 1;
        },
        30s));
    ASSERT_EQ(replay.join(), 0) << replay.output();
    const auto st = pipeline.stats();
    pipeline.stop();

    EXPECT_NE(mismatched.metadata.last_error.find("metadata still says 1024x20"), std::string::npos)
        << mismatched.metadata.last_error;
    EXPECT_GT(st.sensors[1].scans_mode_rejected, 0u);
    EXPECT_GT(st.sensors[1].scans, mismatched.scans);
    EXPECT_TRUE(st.sensors[1].metadata.last_error.empty());
    EXPECT_EQ(ouster::load_metadata(out.path() / "lidar1.json").lidar_mode, "512x20");
    EXPECT_EQ(st.sensors[0].mode_mismatches, 0u);
}

}  // namespace
}  // namespace lidarfuse::reliability
