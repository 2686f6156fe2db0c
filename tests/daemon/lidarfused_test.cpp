// The lidarfused binary: config validation, a simulated station replayed (or sent live)
// through its sockets on loopback, subscribed to over DDS from this process, stopped with
// SIGTERM, and its systemd notify protocol. tf2's view of a run: lidarfused_tf_test.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>

#include "tests/daemon/lidarfused_test_support.hpp"

namespace lidarfuse {
namespace {

using namespace lidarfused_test;  // NOLINT(google-build-using-namespace): the tests' own helpers
using ::testing::HasSubstr;

TEST(Lidarfused, CheckAcceptsAValidConfigAndListsEveryProblemOfABadOne) {
    test::use_loopback_dds();
    test::TempDir dir("lfd");
    ASSERT_NO_FATAL_FAILURE(simulate_two_sensors(dir.path(), 0.1));
    std::string out;
    EXPECT_EQ(test::run_command(test::daemon_path() + " --config " +
                                    (dir.path() / "station.yaml").string() + " --check",
                                &out),
              0)
        << out;
    std::ofstream(dir.path() / "bad.yaml")
        << "sensors:\n  - {name: x, udp_port: 99999, metadata: nope.json}\n"
           "registration: {voxel_size_m: 0}\n";
    out.clear();
    EXPECT_EQ(test::run_command(
                  test::daemon_path() + " --config " + (dir.path() / "bad.yaml").string(), &out),
              1);
    EXPECT_THAT(out, HasSubstr("sensors[0].udp_port"));
    EXPECT_THAT(out, HasSubstr("sensors[0].metadata: file not found"));
    EXPECT_THAT(out, HasSubstr("registration.voxel_size_m"));
}

// --check makes no recording folder, but says when one could not be made; and it names the
// sensors it leaves to be fetched when the daemon runs.
TEST(Lidarfused, CheckRefusesARecordingFolderThatCannotBeMadeAndNamesSensorsByHostname) {
    test::TempDir dir("lfd-check");
    ASSERT_NO_FATAL_FAILURE(simulate_two_sensors(dir.path(), 0.1));
    std::string out;
    std::ofstream(dir.path() / "a_file") << "not a folder";
    std::ofstream(dir.path() / "record.yaml")
        << test::file_text(dir.path() / "station.yaml")
        << "\noutput:\n  dds: {enabled: false}\n  record: {enabled: true, directory: "
        << (dir.path() / "a_file" / "recordings").string() << "}\n";
    out.clear();
    EXPECT_EQ(test::run_command(test::daemon_path() + " --config " +
                                    (dir.path() / "record.yaml").string() + " --check",
                                &out),
              1);
    EXPECT_THAT(
        out,
        HasSubstr("output.record.directory: " + (dir.path() / "a_file" / "recordings").string() +
                  ": cannot be made, " + (dir.path() / "a_file").string() + " is not a directory"));

    std::ofstream(dir.path() / "host.yaml")
        << "sensors:\n  - {name: a, udp_port: " << base_port() + 4
        << ", hostname: 127.0.0.1, http_port: 9}\noutput: {dds: {enabled: false}, directory: "
        << (dir.path() / "out").string() << ", record: {enabled: true}}\n";
    out.clear();
    EXPECT_EQ(test::run_command(test::daemon_path() + " --config " +
                                    (dir.path() / "host.yaml").string() + " --check",
                                &out),
              0)
        << out;
    EXPECT_THAT(out, HasSubstr("(1 sensors) (1 named by hostname: their metadata is fetched when "
                               "the daemon runs, not by --check)"));
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "out" / "recordings"));
}

TEST(Lidarfused, FusesAReplayedStationOntoDdsAndStopsCleanlyOnSigterm) {
    test::TempDir dir("lfd-run");
    const auto d = dir.path();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 2 --seconds 3 --out " +
                                    (d / "sim").string(),
                                &out),
              0)
        << out;
    // 3 s: the default road frame is fixed once the initial registration (about 1 s, more on
    // a loaded machine) is applied; the frames fused before it are not published.
    const std::uint16_t p0 = base_port(), p1 = static_cast<std::uint16_t>(p0 + 2);
    test::use_loopback_dds();  // this process and the daemon
    const int domain = test::unique_domain_id();
    std::ofstream(d / "sim" / "daemon.yaml")
        << "station: test\nroot: lidar0\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p1
        << ", metadata: lidar1.json}\n"
        // Frames fused at predicted poses whenever fusion falls behind: published like the
        // others (how many depends on the machine; under the sanitizers, most).
        << "network: {bind_address: 127.0.0.1}\nsync: {when_behind: predict}\noutput:\n"
        << "  directory: " << (d / "out").string() << "\n"
        << "  dds: {domain_id: " << domain
        << ", frame_id: station_world, diagnostics_period_ms: 200}\n";
    // Subscribed before the daemon starts, so every frame it publishes can be counted.
    DaemonReaders readers(domain);
    DdsSeen seen;

    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        const std::string config = (d / "sim" / "daemon.yaml").string();
        const std::string log = (d / "daemon.log").string();
        std::freopen(log.c_str(), "w", stderr);
        std::freopen(log.c_str(), "a", stdout);
        ::execl(test::daemon_path().c_str(), "lidarfused", "--config", config.c_str(), nullptr);
        ::_exit(127);
    }
    ChildGuard guard{pid};
    // Wait until it listens (its log says so), then replay through its sockets.
    bool listening = false;
    for (int i = 0; i < 200 && !listening; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        std::ifstream log(d / "daemon.log");
        std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
        listening = text.find("listening on UDP") != std::string::npos;
    }
    ASSERT_TRUE(listening);
    // Named after its program, also after its re-exec for OpenMP's wait policy (`ps`, `top`,
    // `pidof lidarfused`).
    std::ifstream comm("/proc/" + std::to_string(pid) + "/comm");
    std::string process_name;
    std::getline(comm, process_name);
    EXPECT_EQ(process_name, "lidarfused");
    ASSERT_TRUE(readers.points.wait_matched()) << "the daemon's writer was not discovered";
    out.clear();
    std::atomic<int> replay_status{-1};
    std::thread replay([&] {
        replay_status = test::run_command(
            // Half speed: 6 s of frames, most of them after the initial registration.
            test::tool_path() + " replay --rate 0.5 " + (d / "sim" / "capture.pcap").string() +
                " --port-map 7502:" + std::to_string(p0) + " --port-map 7504:" + std::to_string(p1),
            &out);
    });
    // Take while the replay runs and for two seconds after (fusion catching up).
    test::eventually(
        [&] {
            readers.take(&seen);
            return replay_status >= 0;
        },
        12000);
    replay.join();
    EXPECT_EQ(replay_status.load(), 0) << out;
    test::eventually(
        [&] {
            readers.take(&seen);
            return false;
        },
        200);
    ASSERT_EQ(::kill(pid, SIGTERM), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    guard.pid = 0;
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
    // The final diagnostics went out during shutdown; then the daemon's writers are gone.
    EXPECT_TRUE(test::eventually([&] {
        readers.take(&seen);
        dds_subscription_matched_status_t st{};
        dds_get_subscription_matched_status(readers.diagnostics.reader(), &st);
        return st.current_count == 0;
    }));

    std::ifstream log(d / "daemon.log");
    const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    if (world_frame_never_fixed(text)) {
        GTEST_SKIP()
            << "the initial registration outlasted the replay: no road frame, nothing published";
    }
    // How many frames get fused depends on the machine (a slow fusion drops the oldest
    // frames, counted); what must hold is that every fused frame has its root pose written.
    const auto fused = test::line_after(text, "stopped: fused ");
    ASSERT_TRUE(fused.has_value()) << text;
    // Normal life is logged at info, and the stop line says each sensor's state.
    EXPECT_NE(text.find("[fusion] [info] frame 0: lidar0: initialised"), std::string::npos) << text;
    EXPECT_EQ(text.find("[warning] frame 0: lidar0: initialised"), std::string::npos) << text;
    EXPECT_NE(fused->find("; sensors: "), std::string::npos) << *fused;
    const auto poses = io::read_pose_csv(d / "out" / "poses.csv");
    std::size_t root_rows = 0;
    for (const auto& p : poses) root_rows += p.sensor == "lidar0";
    EXPECT_GE(root_rows, 1u) << text;
    // Frames fused before the world frame (road, the default) was known are not published.
    const auto unpublished = test::line_after(text, "dropped, ");
    ASSERT_TRUE(unpublished.has_value()) << text;
    const std::size_t all_fused = std::stoul(*fused);
    const std::size_t frames_fused = all_fused - std::stoul(*unpublished);
    EXPECT_EQ(root_rows, frames_fused) << text;

    // DDS: one cloud, one poses message and one tf message per fused frame, none lost.
    EXPECT_EQ(seen.clouds, frames_fused) << text;
    EXPECT_EQ(seen.cloud_stamps.size(), frames_fused);
    EXPECT_EQ(seen.poses, frames_fused);
    EXPECT_EQ(seen.pose_frames.size(), frames_fused);
    EXPECT_EQ(seen.tf_messages, frames_with_tf(seen));
    EXPECT_GT(seen.points, 1000u * frames_fused);
    EXPECT_TRUE(seen.cloud_sensor_ids.count(0));  // the root's points, at least, are in the clouds
    // Intensity is the sensors' signal: most returns of the simulated street have some.
    EXPECT_GT(seen.sampled_with_intensity, seen.sampled_points / 2)
        << seen.sampled_with_intensity << " of " << seen.sampled_points << " sampled points";
    EXPECT_TRUE(seen.all_ok_seen) << "no diagnostics with every sensor OK";
    EXPECT_EQ(seen.last_pipeline["frames_fused"], std::to_string(all_fused));  // published or not
    // Frames fused at predicted poses while fusion was behind (how many depends on the
    // machine): counted, published like the others, and never two in a row.
    const std::size_t predicted = std::stoul(seen.last_pipeline["frames_predicted"]);
    EXPECT_LE(seen.predicted_frames.size(), predicted);
    for (const std::int64_t f : seen.predicted_frames)
        EXPECT_EQ(seen.predicted_frames.count(f + 1), 0u) << "frames " << f << " and " << f + 1;
    std::printf("lidarfused over DDS: %zu of %zu frames fused at predicted poses\n", predicted,
                all_fused);
    EXPECT_EQ(seen.last_pipeline["frames_before_world_frame"],
              std::to_string(all_fused - frames_fused));
    EXPECT_EQ(seen.last_pipeline["world_frame"], "road");
    // The registration that made the road frame known is timed (its log line says the same).
    EXPECT_TRUE(test::line_after(text, "initial registration done in ").has_value()) << text;
    EXPECT_GT(std::stod(seen.last_pipeline["last_initial_registration_ms"]), 0.0);
    EXPECT_EQ(seen.last_pipeline["world_frame_fixed"], "true");
    EXPECT_EQ(seen.last_pipeline["dds_write_failures"], "0");
    EXPECT_EQ(seen.last_pipeline["kernel_drops"], "0");
    std::string registered_names;
    for (const auto& name : seen.registered) registered_names += " " + name;
    std::printf("lidarfused over DDS: %zu frames fused, %zu clouds, %zu points, registered:%s\n",
                frames_fused, seen.clouds, seen.points, registered_names.c_str());
    // Every sensor the daemon registered, the root included, is on rt/tf and in the clouds;
    // none is on rt/tf_static (they move), and tf2 resolves every cloud's stamp.
    std::set<std::string> on_tf;
    for (const auto& r : seen.tf) on_tf.insert(r.sensor);
    EXPECT_TRUE(seen.registered.count("lidar0"));
    EXPECT_EQ(on_tf, seen.registered);
    EXPECT_LE(expect_every_cloud_resolves(seen), 1u);  // at most lidar1's first frame on tf
    if (seen.registered.count("lidar1")) {
        EXPECT_TRUE(seen.cloud_sensor_ids.count(1));
    }

    // rt/tf against the simulator's ground truth, with the same evaluator as poses.csv.
    io::write_pose_csv(d / "tf.csv", seen.tf);
    std::string tf_eval;
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " +
                                    (d / "sim" / "ground_truth.csv").string() + " --poses " +
                                    (d / "tf.csv").string() + " --root lidar0",
                                &tf_eval),
              0)
        << tf_eval;
    EXPECT_THAT(tf_eval, HasSubstr("eval_mean_strict_rmse_trans 0.0")) << tf_eval;  // below 10 cm
    std::printf("rt/tf against ground truth: strict RMSE %s\n",
                test::line_after(tf_eval, "eval_mean_strict_rmse_trans ").value_or("?").c_str());
    std::string root;
    const auto extrinsics = io::read_extrinsics_yaml(d / "out" / "extrinsics.yaml", &root);
    EXPECT_EQ(root, "lidar0");
    ASSERT_EQ(extrinsics.size(), 2u);
    EXPECT_TRUE(extrinsics[0].registered);
    for (const auto& e : extrinsics)
        EXPECT_EQ(e.registered, seen.registered.count(e.name) > 0) << e.name;
    EXPECT_FALSE(std::filesystem::exists(d / "out" / "extrinsics.yaml.tmp"));

    out.clear();
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " +
                                    (d / "sim" / "ground_truth.csv").string() + " --poses " +
                                    (d / "out" / "poses.csv").string(),
                                &out),
              0)
        << out;
    EXPECT_THAT(out, HasSubstr("eval_mean_strict_rmse_trans 0.0"));  // centimetres, not metres
}

// Fusion far behind the sensors: a capture replayed at 4x into a frame queue deep enough
// for all of it (sync.queue_depth 64), so a frame always waits when fusion finishes one.
// With sync.when_behind: predict a predicted frame is always followed by a registered one
// (once every sensor's fit is confirmed, most frames alternate), none is dropped, every one
// is published, and the predicted poses are in the run's accuracy.
TEST(Lidarfused, FramesThatWaitWhileFusionIsBehindAreFusedAtPredictedPoses) {
    test::use_loopback_dds();
    test::TempDir dir("lfd-predict");
    const auto d = dir.path();
    ASSERT_NO_FATAL_FAILURE(simulate_two_sensors(d / "sim", 3.0));
    const auto p0 = static_cast<std::uint16_t>(base_port() + 12);  // beside the other tests'
    const int domain = test::unique_domain_id();
    std::ofstream(d / "sim" / "daemon.yaml")
        << "station: test\nroot: lidar0\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p0 + 2 << ", metadata: lidar1.json}\n"
        << "network: {bind_address: 127.0.0.1}\nsync: {queue_depth: 64, when_behind: predict}\n"
        << "world: {frame: sensor}\noutput:\n  directory: " << (d / "out").string() << "\n"
        << "  dds: {domain_id: " << domain << ", frame_id: station_world}\n";
    DaemonReaders readers(domain);
    DdsSeen seen;
    FedRun run;
    ASSERT_NO_FATAL_FAILURE(
        run_fed_daemon(d / "sim" / "daemon.yaml", d / "daemon.log",
                       replay_two_sensors("--rate 4", d / "sim" / "capture.pcap", p0), 3000,
                       &readers, &seen, &run));
    const std::string log = read_text(d / "daemon.log");
    const std::size_t fused = std::stoul(seen.last_pipeline["frames_fused"]);
    const std::size_t predicted = std::stoul(seen.last_pipeline["frames_predicted"]);
    std::printf("lidarfused behind: %zu frames fused, %zu at predicted poses, %s dropped\n", fused,
                predicted, seen.last_pipeline["frame_queue_drops"].c_str());
    EXPECT_EQ(seen.last_pipeline["frame_queue_drops"], "0") << log;
    // A frame is fused at predicted poses once every tracked sensor's fit is confirmed:
    // prediction_min_poses (4) registered poses, then a registered frame checked against
    // them. So lidar1, tracked from when its initial registration is applied, needs five
    // registered frames before one can be predicted; the sanitizers' fusion on a loaded
    // machine may fuse fewer in the test's time (5 frames in all, none predicted, once).
    std::size_t lidar1_frames = 0;
    for (const auto& p : io::read_pose_csv(d / "out" / "poses.csv"))
        lidar1_frames += p.sensor == "lidar1";
    if (predicted == 0 && lidar1_frames < 6)
        GTEST_SKIP() << "fusion too slow for the run: " << fused << " frames fused, "
                     << lidar1_frames << " with lidar1";
    EXPECT_GT(predicted, 0u) << log;
    EXPECT_LE(predicted, fused / 2 + 1)
        << "a predicted frame is always followed by a registered one";
    EXPECT_EQ(seen.poses, fused) << "every frame published, predicted or not";
    EXPECT_EQ(seen.predicted_frames.size(), predicted);
    for (const std::int64_t f : seen.predicted_frames)
        EXPECT_EQ(seen.predicted_frames.count(f + 1), 0u) << "frames " << f << " and " << f + 1;
    EXPECT_THAT(log, HasSubstr("at predicted poses)"));  // the stop line says how many
    std::string eval;
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " +
                                    (d / "sim" / "ground_truth.csv").string() + " --poses " +
                                    (d / "out" / "poses.csv").string() + " --root lidar0",
                                &eval),
              0)
        << eval;
    const double rmse_m =
        std::stod(test::line_after(eval, "eval_mean_strict_rmse_trans ").value_or("1e9"));
    std::printf("lidarfused behind: strict RMSE %.4f m over every pose written\n", rmse_m);
    EXPECT_LT(rmse_m, 0.02) << eval;
}

// `lidarfuse sim --live` sends a station's packets in real time while it simulates them
// (no capture file): the daemon fuses them and publishes every fused frame on DDS.
TEST(Lidarfused, FusesALiveSimulatedStationOntoDds) {
    test::use_loopback_dds();
    test::TempDir dir("lfd-live");
    const auto d = dir.path();
    // The metadata of the same virtual sensors, before the live run starts.
    ASSERT_NO_FATAL_FAILURE(simulate_two_sensors(d / "meta", 0.05));
    const auto p0 = static_cast<std::uint16_t>(base_port() + 8);  // beside base_port()'s
    const int domain = test::unique_domain_id();
    std::ofstream(d / "meta" / "daemon.yaml")
        << "station: live\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p0 + 2
        << ", metadata: lidar1.json}\n"
        // The root frame: the 1 s live run can end before the initial registration fixes a
        // road frame (the default, tested with a replay above), and this test is about every
        // fused frame reaching DDS.
        << "network: {bind_address: 127.0.0.1}\nworld: {frame: sensor}\noutput:\n  directory: "
        << (d / "out").string() << "\n"
        << "  dds: {domain_id: " << domain << ", frame_id: station_world}\n";
    DaemonReaders readers(domain);
    DdsSeen seen;
    FedRun run;
    ASSERT_NO_FATAL_FAILURE(run_fed_daemon(
        d / "meta" / "daemon.yaml", d / "daemon.log",
        test::tool_path() + " sim --scenario curve --sensors 2 --seconds 1 --live --to 127.0.0.1:" +
            std::to_string(p0) + " --out " + (d / "live").string(),
        12000, &readers, &seen, &run));
    const std::string text = read_text(d / "daemon.log");
    const auto fused = test::line_after(text, "stopped: fused ");
    ASSERT_TRUE(fused.has_value()) << text;
    const std::size_t frames_fused = std::stoul(*fused);
    EXPECT_GE(frames_fused, 1u) << text;
    EXPECT_EQ(seen.clouds, frames_fused) << text;
    EXPECT_EQ(seen.poses, frames_fused);
    EXPECT_EQ(seen.tf_messages, frames_with_tf(seen));
    // Every sensor OK needs lidar1's initial registration, which under the sanitizers (six
    // times slower) can outlast the 1 s live run (seen: 6 frames fused, lidar1 never
    // registered); the release tree registers it well within the run.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    const bool expect_all_ok = seen.registered.size() == 2;
#else
    const bool expect_all_ok = true;
#endif
    if (expect_all_ok) {
        EXPECT_TRUE(seen.all_ok_seen) << "no diagnostics with every sensor OK";
    }
    EXPECT_EQ(seen.last_pipeline["dds_write_failures"], "0");
    io::write_pose_csv(d / "tf.csv", seen.tf);
    std::string tf_eval;
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " +
                                    (d / "live" / "ground_truth.csv").string() + " --poses " +
                                    (d / "tf.csv").string() + " --root lidar0",
                                &tf_eval),
              0)
        << tf_eval;
    EXPECT_THAT(tf_eval, HasSubstr("eval_mean_strict_rmse_trans 0.0")) << tf_eval;
    std::printf("live: %zu frames fused, registered %zu sensors, rt/tf strict RMSE %s\n",
                frames_fused, seen.registered.size(),
                test::line_after(tf_eval, "eval_mean_strict_rmse_trans ").value_or("?").c_str());
}

// The daemon speaks systemd's notify protocol: READY=1 once bound, WATCHDOG=1 while the
// fusion heartbeat is fresh, STATUS= lines, STOPPING=1 on SIGTERM.
TEST(Lidarfused, SpeaksTheSystemdNotifyProtocol) {
    test::use_loopback_dds();
    test::TempDir dir("lfd-notify");
    const auto d = dir.path();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() +
                                    " sim --scenario curve --sensors 1 --seconds 0.1 --out " +
                                    (d / "sim").string(),
                                &out),
              0)
        << out;
    std::ofstream(d / "sim" / "daemon.yaml")
        << "sensors:\n  - {name: lidar0, udp_port: " << base_port() + 1
        << ", metadata: lidar0.json}\n"
        << "network: {bind_address: 127.0.0.1}\noutput: {directory: " << (d / "out").string()
        << ", dds: {domain_id: " << test::unique_domain_id() << "}}\n";
    const std::string socket_path = (d / "notify.sock").string();
    const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    ASSERT_GE(fd, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, socket_path.c_str(), sizeof(addr.sun_path) - 1);
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    timeval tv{20, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));

    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        ::setenv("NOTIFY_SOCKET", socket_path.c_str(), 1);
        ::setenv("WATCHDOG_USEC", "400000", 1);
        ::unsetenv("WATCHDOG_PID");
        const std::string config = (d / "sim" / "daemon.yaml").string();
        std::freopen((d / "daemon.log").string().c_str(), "w", stderr);
        ::execl(test::daemon_path().c_str(), "lidarfused", "--config", config.c_str(), nullptr);
        ::_exit(127);
    }
    const auto receive = [fd] {
        char buffer[1024];
        const ssize_t n = ::recv(fd, buffer, sizeof(buffer), 0);
        return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
    };
    EXPECT_THAT(receive(), HasSubstr("READY=1\nSTATUS=listening on UDP"));
    bool watchdog = false, status = false;
    for (int i = 0; i < 40 && !(watchdog && status); ++i) {
        const auto message = receive();
        watchdog = watchdog || message == "WATCHDOG=1";
        status = status || message.rfind("STATUS=fused ", 0) == 0;
    }
    EXPECT_TRUE(watchdog);
    EXPECT_TRUE(status);
    ASSERT_EQ(::kill(pid, SIGTERM), 0);
    bool stopping = false;
    for (int i = 0; i < 20 && !stopping; ++i) stopping = receive() == "STOPPING=1";
    EXPECT_TRUE(stopping);
    int exit_status = 0;
    ASSERT_EQ(::waitpid(pid, &exit_status, 0), pid);
    EXPECT_TRUE(WIFEXITED(exit_status) && WEXITSTATUS(exit_status) == 0);
    ::close(fd);
}

}  // namespace
}  // namespace lidarfuse
