// The lidarfused binary: config validation, and a simulated station replayed through its
// sockets on loopback, stopped with SIGTERM.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <thread>

#include "drivers/io/extrinsics_yaml.hpp"
#include "drivers/io/pose_csv.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

using ::testing::HasSubstr;

TEST(Lidarfused, CheckAcceptsAValidConfigAndListsEveryProblemOfABadOne) {
    test::TempDir dir("lfd");
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() + " sim --scenario curve --sensors 2 --seconds 0.1 --out " +
                                    dir.path().string(), &out), 0) << out;
    out.clear();
    EXPECT_EQ(test::run_command(test::daemon_path() + " --config " + (dir.path() / "station.yaml").string() +
                                    " --check", &out), 0) << out;
    std::ofstream(dir.path() / "bad.yaml") << "sensors:\n  - {name: x, udp_port: 99999, metadata: nope.json}\n"
                                              "registration: {voxel_size_m: 0}\n";
    out.clear();
    EXPECT_EQ(test::run_command(test::daemon_path() + " --config " + (dir.path() / "bad.yaml").string(), &out), 1);
    EXPECT_THAT(out, HasSubstr("sensors[0].udp_port"));
    EXPECT_THAT(out, HasSubstr("sensors[0].metadata: file not found"));
    EXPECT_THAT(out, HasSubstr("registration.voxel_size_m"));
}

// Ports for this test: distinct per process so parallel test runs do not collide.
std::uint16_t base_port() { return static_cast<std::uint16_t>(42000 + (::getpid() % 4000) * 4); }

TEST(Lidarfused, FusesAReplayedStationAndStopsCleanlyOnSigterm) {
    test::TempDir dir("lfd-run");
    const auto d = dir.path();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() + " sim --scenario curve --sensors 2 --seconds 1 --out " +
                                    (d / "sim").string(), &out), 0) << out;
    const std::uint16_t p0 = base_port(), p1 = static_cast<std::uint16_t>(p0 + 2);
    std::ofstream(d / "sim" / "daemon.yaml")
        << "station: test\nroot: lidar0\nsensors:\n"
        << "  - {name: lidar0, udp_port: " << p0 << ", metadata: lidar0.json}\n"
        << "  - {name: lidar1, udp_port: " << p1 << ", metadata: lidar1.json}\n"
        << "network: {bind_address: 127.0.0.1}\noutput: {directory: " << (d / "out").string() << "}\n";

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
    // Wait until it listens (its log says so), then replay through its sockets.
    bool listening = false;
    for (int i = 0; i < 200 && !listening; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        std::ifstream log(d / "daemon.log");
        std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
        listening = text.find("listening on UDP") != std::string::npos;
    }
    ASSERT_TRUE(listening);
    out.clear();
    EXPECT_EQ(test::run_command(test::tool_path() + " replay " + (d / "sim" / "capture.pcap").string() +
                                    " --port-map 7502:" + std::to_string(p0) + " --port-map 7504:" +
                                    std::to_string(p1), &out), 0) << out;
    std::this_thread::sleep_for(std::chrono::seconds(2));  // let fusion catch up
    ASSERT_EQ(::kill(pid, SIGTERM), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);

    std::ifstream log(d / "daemon.log");
    const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    // How many frames get fused depends on the machine (a slow fusion drops the oldest
    // frames, counted); what must hold is that every fused frame has its root pose written.
    const auto fused = test::line_after(text, "stopped: fused ");
    ASSERT_TRUE(fused.has_value()) << text;
    const auto poses = io::read_pose_csv(d / "out" / "poses.csv");
    std::size_t root_rows = 0;
    for (const auto& p : poses) root_rows += p.sensor == "lidar0";
    EXPECT_GE(root_rows, 1u) << text;
    EXPECT_EQ(root_rows, std::stoul(*fused)) << text;
    std::string root;
    const auto extrinsics = io::read_extrinsics_yaml(d / "out" / "extrinsics.yaml", &root);
    EXPECT_EQ(root, "lidar0");
    ASSERT_EQ(extrinsics.size(), 2u);
    EXPECT_TRUE(extrinsics[0].registered);
    EXPECT_FALSE(std::filesystem::exists(d / "out" / "extrinsics.yaml.tmp"));

    out.clear();
    ASSERT_EQ(test::run_command(test::tool_path() + " eval --gt " + (d / "sim" / "ground_truth.csv").string() +
                                    " --poses " + (d / "out" / "poses.csv").string(), &out), 0) << out;
    EXPECT_THAT(out, HasSubstr("eval_mean_strict_rmse_trans 0.0"));  // centimetres, not metres
}

// The daemon speaks systemd's notify protocol: READY=1 once bound, WATCHDOG=1 while the
// fusion heartbeat is fresh, STATUS= lines, STOPPING=1 on SIGTERM.
TEST(Lidarfused, SpeaksTheSystemdNotifyProtocol) {
    test::TempDir dir("lfd-notify");
    const auto d = dir.path();
    std::string out;
    ASSERT_EQ(test::run_command(test::tool_path() + " sim --scenario curve --sensors 1 --seconds 0.1 --out " +
                                    (d / "sim").string(), &out), 0) << out;
    std::ofstream(d / "sim" / "daemon.yaml")
        << "sensors:\n  - {name: lidar0, udp_port: " << base_port() + 1 << ", metadata: lidar0.json}\n"
        << "network: {bind_address: 127.0.0.1}\noutput: {directory: " << (d / "out").string() << "}\n";
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
