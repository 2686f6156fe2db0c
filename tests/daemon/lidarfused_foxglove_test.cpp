// lidarfused's live view with a real Foxglove client (tests/foxglove/client.cjs on Node, with
// Foxglove's own npm packages): a replay through the daemon, a client that decodes clouds and
// tf (compared with poses.csv), one that stops reading, and one past max_clients.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/daemon/lidarfused_test_support.hpp"

namespace lidarfuse {
namespace {

using namespace lidarfused_test;  // NOLINT(google-build-using-namespace): the tests' own helpers
using ::testing::HasSubstr;
using Json = nlohmann::json;

#if defined(__SANITIZE_THREAD__)
constexpr bool kThreadSanitizer = true;
#else
constexpr bool kThreadSanitizer = false;
#endif

const std::filesystem::path kClientModules = test::foxglove_client_dir() / "node_modules";

// `node client.cjs URL MODE OUT` in the background, its output to OUT.log.
pid_t start_client(const std::string& url, const std::string& mode,
                   const std::filesystem::path& out) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        std::freopen((out.string() + ".log").c_str(), "w", stderr);
        std::freopen((out.string() + ".log").c_str(), "a", stdout);
        ::setenv("NODE_PATH", kClientModules.c_str(), 1);
        const auto script = test::source_dir() / "tests" / "foxglove" / "client.cjs";
        ::execlp("node", "node", script.c_str(), url.c_str(), mode.c_str(), out.c_str(), nullptr);
        ::_exit(127);
    }
    return pid;
}

Json stop_client(ChildGuard* client, const std::filesystem::path& out) {
    ::kill(client->pid, SIGTERM);
    ::waitpid(client->pid, nullptr, 0);
    client->pid = 0;
    std::ifstream in(out);
    if (!in) {
        ADD_FAILURE() << "the client wrote nothing: " << read_text(out.string() + ".log");
        return Json::object();
    }
    return Json::parse(in);
}

bool wait_for_file(const std::filesystem::path& file) {
    // Node starts slowly on a loaded machine (seen: over 10 s at a load of 7 on 2 cores).
    return test::eventually([&] { return std::filesystem::exists(file); }, 6000);
}

// The last "fused N frames" of the daemon's stop line.
long frames_fused(const std::string& log) {
    const auto at = log.rfind("stopped: fused ");
    return at == std::string::npos ? -1 : std::stol(log.substr(at + 15));
}

struct Station {
    std::filesystem::path dir, config;
    std::uint16_t p0 = 0, ws_port = 0;
    std::string replay;
};

// The live view's run also serves the thinned cloud (/lidarfuse/points_voxel), except under
// TSan: there the output thread, many times slower, can fall behind with the second cloud
// and its queue drop frames (seen once: 21 of 28 published), which the check that the
// stalled client costs nothing would take for the client's fault. The thinning runs on the
// output thread alone; the release and ASan runs check it end to end.
bool thinned_cloud(bool foxglove) { return foxglove && !kThreadSanitizer; }

void write_station(Station* s, bool foxglove) {
    const int domain = test::unique_domain_id();
    s->config = s->dir / "sim" / (foxglove ? "fox.yaml" : "plain.yaml");
    std::ofstream(s->config)
        << "station: fox\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << s->p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << s->p0 + 2
        << ", metadata: lidar1.json}\n"
        // One fusion thread: no OpenMP team, whose threads (Debian's libgomp is not built with
        // TSan, and the fusion's num_threads clause overrides OMP_NUM_THREADS) TSan would
        // report as races in the TSan stage; the live view is what this test is about.
        << "registration: {threads: 1}\n"
        // The sensor frame: frames are published from the first one, not after the road fit.
        << "network: {bind_address: 127.0.0.1}\nworld: {frame: sensor}\noutput:\n  directory: "
        << (s->dir / (foxglove ? "out" : "out-plain")).string() << "\n"
        << "  dds: {domain_id: " << domain << ", diagnostics_period_ms: 200"
        << (thinned_cloud(foxglove) ? ", points_voxel_size_m: 0.5" : "") << "}\n"
        << "  foxglove: {enabled: " << (foxglove ? "true" : "false") << ", port: "
        << s->ws_port
        // 2 MiB per client: two or three clouds of this station (0.5-0.8 MB each), so a
        // client that stops reading overfills it within the replay, kernel buffers included.
        << ", max_clients: 2, client_buffer_mb: 2}\n";
}

// After a replay: lidarfused is done once its initial registration has ended and poses.csv
// (written as each frame is published) has stopped growing for a second. A fixed pause is not
// enough: under TSan on a loaded machine the registration ended 3 s after the replay, and the
// frames it held back were published after the viewer had gone.
void wait_until_published(const std::filesystem::path& log, const std::filesystem::path& poses) {
    EXPECT_TRUE(test::eventually(
        [&] { return read_text(log).find("initial registration done") != std::string::npos; },
        6000))
        << read_text(log);
    const auto size_of = [&] {
        std::error_code ec;
        const auto n = std::filesystem::file_size(poses, ec);
        return ec ? std::uintmax_t{0} : n;
    };
    auto last = size_of();
    for (int tries = 0, unchanged = 0; tries < 300 && unchanged < 10; ++tries) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        const auto now = size_of();
        unchanged = now == last ? unchanged + 1 : 0;
        last = now;
    }
}

// A replay of the station through lidarfused with nothing connected: the frames fused when
// no client costs anything, to compare with the run that has a stalled client.
long baseline_frames(const Station& s) {
    ChildGuard daemon{start_daemon(s.config, s.dir / "plain.log")};
    EXPECT_TRUE(test::eventually(
        [&] {
            return read_text(s.dir / "plain.log").find("listening on UDP") != std::string::npos;
        },
        3000));
    std::string out;
    EXPECT_EQ(test::run_command(s.replay, &out), 0) << out;
    wait_until_published(s.dir / "plain.log", s.dir / "out-plain" / "poses.csv");
    ::kill(daemon.pid, SIGTERM);
    ::waitpid(daemon.pid, nullptr, 0);
    daemon.pid = 0;
    return frames_fused(read_text(s.dir / "plain.log"));
}

// tf as the client decoded it against poses.csv, row by row (sensor and stamp): the same
// T_fused_sensor to the CSV's precision (1 um, 1e-9 in the quaternion).
std::size_t expect_tf_matches_poses(const Json& tf, const std::vector<io::PoseRecord>& csv) {
    std::map<std::pair<std::string, std::int64_t>, Eigen::Isometry3d> by_stamp;
    for (const auto& r : csv) by_stamp[{r.sensor, r.t_ns}] = r.pose;
    std::size_t matched = 0;
    for (const auto& t : tf) {
        EXPECT_EQ(t[1], "lidarfuse/fused");
        const auto it =
            by_stamp.find({t[0].get<std::string>(), std::stoll(t[2].get<std::string>())});
        if (it == by_stamp.end()) {
            ADD_FAILURE() << "tf of " << t[0] << " at " << t[2] << " is not in poses.csv";
            continue;
        }
        const auto v = [&](int i) { return t[static_cast<std::size_t>(i)].get<double>(); };
        const Eigen::Vector3d p(v(3), v(4), v(5));
        const Eigen::Quaterniond q(v(6), v(7), v(8), v(9));
        EXPECT_LT((p - it->second.translation()).norm(), 2e-6) << t;
        EXPECT_LT(q.angularDistance(Eigen::Quaterniond(it->second.linear())), 1e-7) << t;
        ++matched;
    }
    return matched;
}

TEST(LidarfusedFoxglove, ANodeClientDecodesCloudsAndTfOfAReplayWhileAStalledOneOnlyLosesItsOwn) {
    if (test::run_command("node --version", nullptr) != 0 ||
        !std::filesystem::exists(kClientModules / "@foxglove" / "ws-protocol")) {
        GTEST_SKIP() << "no node or no Foxglove client in " << kClientModules
                     << ": run tests/foxglove/install.sh <build folder> (scripts/test.sh does)";
    }
    test::use_loopback_dds();
    test::TempDir dir("lfd-foxglove");
    Station s{dir.path(), {}, test::port_block(), 0, ""};
    s.ws_port = static_cast<std::uint16_t>(s.p0 + 8);  // TCP, beside this block's UDP ports
    // Under TSan the initial registration takes 6-7 s and starts a few seconds into the
    // replay (seen: done 4 s after a 5 s replay had ended, so no frame carried a pose).
    ASSERT_NO_FATAL_FAILURE(simulate_two_sensors(s.dir / "sim", kThreadSanitizer ? 10 : 5));
    s.replay = test::tool_path() + " replay " + (s.dir / "sim" / "capture.pcap").string() +
               " --port-map 7502:" + std::to_string(s.p0) +
               " --port-map 7504:" + std::to_string(s.p0 + 2);
    write_station(&s, false);
    const long baseline = baseline_frames(s);
    write_station(&s, true);

    const auto log = s.dir / "daemon.log";
    ChildGuard daemon{start_daemon(s.config, log)};
    ASSERT_TRUE(test::eventually(
        [&] { return read_text(log).find("foxglove: live view on ws://") != std::string::npos; },
        3000))
        << read_text(log);
    const std::string url = "ws://127.0.0.1:" + std::to_string(s.ws_port);
    ChildGuard viewer{start_client(url, "record", s.dir / "viewer.json")};
    ASSERT_TRUE(wait_for_file(s.dir / "viewer.json.ready")) << read_text(s.dir / "viewer.json.log");
    ChildGuard stalled{start_client(url, "stall", s.dir / "stalled.json")};
    ASSERT_TRUE(wait_for_file(s.dir / "stalled.json.ready"))
        << read_text(s.dir / "stalled.json.log");
    ChildGuard third{start_client(url, "refused", s.dir / "third.json")};  // past max_clients: 2
    ASSERT_TRUE(wait_for_file(s.dir / "third.json")) << read_text(s.dir / "third.json.log");
    const Json refused = Json::parse(read_text(s.dir / "third.json"));
    EXPECT_EQ(refused.value("refusedStatus", 0), 503) << refused;

    std::string replay_out;
    ASSERT_EQ(test::run_command(s.replay, &replay_out), 0) << replay_out;
    wait_until_published(log, s.dir / "out" / "poses.csv");
    const Json seen = stop_client(&viewer, s.dir / "viewer.json");
    // The daemon stops promptly although a client never reads again (its close is cut off).
    const auto stop_started = std::chrono::steady_clock::now();
    ASSERT_EQ(::kill(daemon.pid, SIGTERM), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(daemon.pid, &status, 0), daemon.pid);
    daemon.pid = 0;
    const double stop_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - stop_started).count();
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    EXPECT_LT(stop_s, 5.0);
    const std::string text = read_text(log);
    const auto csv = io::read_pose_csv(s.dir / "out" / "poses.csv");
    std::set<std::int64_t> frames;
    for (const auto& r : csv) frames.insert(r.frame);
    if (frames.empty() && kThreadSanitizer) {
        // What follows needs frames with poses. The daemon's threads ran under TSan all the
        // same (a race would have stopped the process); the release and ASan runs check it.
        GTEST_SKIP() << "under TSan the initial registration outlasted the replay: no frame "
                        "was published with a pose\n"
                     << text;
    }

    // What the viewer decoded: every schema parsed, every message CDR_LE and readable.
    EXPECT_TRUE(seen["schemaErrors"].empty()) << seen["schemaErrors"];
    EXPECT_TRUE(seen["decodeErrors"].empty()) << seen["decodeErrors"];
    EXPECT_EQ(seen["encapsulations"], Json::array({1})) << "CDR_LE only";
    EXPECT_EQ(seen["serverName"], "lidarfused fox");
    Json topics =
        Json::array({"/lidarfuse/points", "/tf", "/tf_static", "/diagnostics", "/lidarfuse/poses"});
    if (thinned_cloud(true)) topics.push_back("/lidarfuse/points_voxel");
    EXPECT_EQ(seen["topics"], topics);
    EXPECT_EQ(seen["cloudFrame"], "lidarfuse/fused");
    EXPECT_EQ(seen["cloudFields"], Json::array({"x:0:7", "y:4:7", "z:8:7", "intensity:12:7",
                                                "sensor_id:16:2", "dynamic:17:2"}));
    EXPECT_EQ(seen["cloudSizeErrors"], 0);
    EXPECT_GT(seen["sampledPoints"].get<long>(), 0);
    EXPECT_EQ(seen["finitePoints"], seen["sampledPoints"]);
    EXPECT_GT(seen["diagnostics"].get<long>(), 0);

    const std::size_t matched = expect_tf_matches_poses(seen["tf"], csv);
    const long clouds = seen["clouds"].get<long>();
    const long poses = seen["poses"].get<long>();  // one per published frame
    const long fused = frames_fused(text);
    std::printf(
        "foxglove: baseline fused %ld, with clients %ld, published %zu; viewer: %ld clouds "
        "(%ld points), %zu tf matched, %ld poses; stopped in %.2f s\n",
        baseline, fused, frames.size(), clouds, seen["cloudPoints"].get<long>(), matched,
        seen["poses"].get<long>(), stop_s);
    ASSERT_FALSE(frames.empty()) << text;
    EXPECT_GT(matched, frames.size() / 2);
    // A viewer that keeps up gets most clouds (it shares the 2 cores with the daemon).
    EXPECT_GE(clouds, poses / 2);
    // The thinned cloud (0.5 m voxels) beside it, far smaller than the full one.
    const long voxel_clouds = seen["voxelClouds"].get<long>();
    if (thinned_cloud(true)) {
        EXPECT_GE(voxel_clouds, poses / 2);
    }
    if (voxel_clouds > 0 && clouds > 0) {
        const double full = seen["cloudPoints"].get<double>() / static_cast<double>(clouds);
        const double thin = seen["voxelPoints"].get<double>() / static_cast<double>(voxel_clouds);
        std::printf("foxglove: %.0f points per cloud, %.0f per thinned cloud\n", full, thin);
        EXPECT_GT(thin, 0.0);
        EXPECT_LT(thin, 0.8 * full);
    }
    // The stalled client costs neither the output thread nor fusion: every frame fused was
    // published (a server that waited for the stalled client would hold the output thread,
    // whose queue drops the oldest), and fusion fused about as many frames as with no client
    // at all. That bound is loose: the initial registration's worker (2-5 s here) and the
    // viewer's own decoding share the 2 cores, so the count varies from run to run.
    // (poses.csv has rows of registered sensors only: under TSan the frames before the
    // initial registration ended have none, so the poses messages count the published.)
    // The frames fused are those of the last /diagnostics the viewer read, not the stop
    // line's: fusion may still empty its queue after the viewer has gone (seen under TSan:
    // the initial registration ended a second before the replay, and the last 9 frames of a
    // burst were fused after the viewer's disconnect, so 43 poses against 49 fused).
    const auto& pipeline = seen["lastPipeline"];
    const long fused_while_viewing = std::stol(pipeline.value("frames_fused", "0"));
    EXPECT_GT(fused_while_viewing, 0) << pipeline;
    EXPECT_LE(fused_while_viewing, fused);
    EXPECT_GE(poses, fused_while_viewing * 9 / 10) << pipeline << "\n" << text;
    if (kThreadSanitizer) {
        // Under TSan fusion takes about a second a frame, so both runs fuse a handful of
        // frames, or a few dozen when the scheduler favours fusion over the registration's
        // worker (seen: a baseline of 37 beside 4): a count that says nothing of the client.
        std::printf("foxglove: frames fused not compared with the baseline under TSan\n");
    } else {
        EXPECT_GE(fused, baseline / 3) << text;
    }

    // The refused connection is counted, and so are the stalled client's losses (in the
    // diagnostics the viewer read and in the stop line) once more was sent than its buffers
    // hold: its 2 MiB and the kernel's (the server's socket grows to 4 MiB, net.ipv4.tcp_wmem;
    // a receiver that never reads keeps its initial window). A slow build (a sanitizer on a
    // loaded machine: 4 clouds, 1.7 MB) may send less than that; it says so.
    EXPECT_EQ(pipeline.value("foxglove_refused", ""), "1") << pipeline;
    EXPECT_THAT(text, HasSubstr("foxglove: 2 connections (1 refused)"));
    const double cloud_mb = seen["cloudBytes"].get<double>() * 1e-6;
    if (cloud_mb > 12.0) {
        EXPECT_NE(pipeline.value("foxglove_messages_dropped", "0"), "0") << pipeline;
        EXPECT_THAT(text, ::testing::Not(HasSubstr(", 0 dropped for slow clients")));
    } else {
        std::printf(
            "foxglove: only %.1f MB of clouds sent, within the stalled client's buffers: "
            "its drops not checked\n",
            cloud_mb);
    }
    stop_client(&stalled, s.dir / "stalled.json");
}

}  // namespace
}  // namespace lidarfuse
