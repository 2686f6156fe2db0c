// `lidarfuse sim --live --to HOST:PORT` sends every packet over UDP at the capture's pace.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "drivers/ouster/packet_format.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

TEST(SimLive, SendsEveryPacketToTheSensorsPortsInRealTime) {
    // Bind the receiving port first (ephemeral), then point the simulator at it.
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    ASSERT_GE(fd, 0);
    int rcvbuf = 8 << 20;
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = 0;
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    socklen_t len = sizeof(addr);
    ASSERT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len), 0);
    const int port = ntohs(addr.sin_port);
    timeval tv{0, 200'000};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));

    std::atomic<bool> stop{false};
    std::atomic<int> good{0};
    std::thread rx([&] {
        std::vector<std::uint8_t> buf(70000);
        const ouster::PacketFormat f(ouster::UdpProfileLidar::kLegacy, 64, 16);
        while (!stop) {
            const auto n = ::recv(fd, buf.data(), buf.size(), 0);
            if (n > 0 &&
                f.classify(buf.data(), static_cast<std::size_t>(n)) == ouster::PacketKind::kLidar)
                ++good;
        }
    });
    test::TempDir dir("sim_live");
    std::string log;
    const int rc = test::run_command(test::tool_path() +
                                         " sim --scenario straight --sensors 1 --seconds 0.5"
                                         " --mode 512x20 --no-traffic --live --to 127.0.0.1:" +
                                         std::to_string(port) + " --out " + dir.path().string(),
                                     &log);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    stop = true;
    rx.join();
    ::close(fd);
    ASSERT_EQ(rc, 0) << log;
    EXPECT_NE(log.find("sim_live_sent 320 datagrams"), std::string::npos) << log;
    EXPECT_EQ(good.load(), 320);  // 10 frames x 32 packets, on loopback nothing is lost
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "station.yaml"));
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "capture.pcap"));
}

}  // namespace
}  // namespace lidarfuse
