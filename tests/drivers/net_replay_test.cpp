// Replay of real captures through loopback UDP into UdpReceiver: every datagram arrives
// byte-identical to what PcapReader gives, through the library and the `lidarfuse replay`
// binary; port mapping, one source socket per original sender, looping, stopping.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "drivers/net/udp_receiver.hpp"
#include "drivers/pcap/pcap_reader.hpp"
#include "drivers/pcap/replay.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

struct Sent {
    std::uint16_t dst_port;
    std::uint32_t src_ip;
    std::uint16_t src_port;
    std::vector<std::uint8_t> data;
};

std::vector<Sent> read_capture(const std::filesystem::path& file) {
    pcap::PcapReader reader(file);
    std::vector<Sent> out;
    pcap::UdpDatagram d;
    while (reader.next(&d)) {
        out.push_back(
            {d.dst_port, d.src_ip, d.src_port, std::vector<std::uint8_t>(d.data, d.data + d.size)});
    }
    return out;
}

struct Arrived {
    std::size_t socket_index;
    std::uint16_t src_port;
    std::vector<std::uint8_t> data;
};

// A receiver on ephemeral loopback ports, running on its own thread.
class Listener {
public:
    explicit Listener(std::size_t ports) {
        net::UdpReceiverParams p;
        p.bind_address = "127.0.0.1";
        p.ports.assign(ports, 0);
        receiver_ = std::make_unique<net::UdpReceiver>(p);
        thread_ = std::thread([this] {
            receiver_->run([this](const net::ReceivedDatagram& d) {
                std::lock_guard<std::mutex> lock(mutex_);
                arrived_.push_back({d.socket_index, d.src_port,
                                    std::vector<std::uint8_t>(d.data, d.data + d.size)});
            });
        });
    }
    ~Listener() { stop(); }
    std::uint16_t port(std::size_t i) const { return receiver_->sockets()[i].port; }
    // Waits (bounded) until `count` datagrams have arrived, then stops the receiver.
    std::vector<Arrived> wait_for(std::size_t count) {
        for (int i = 0; i < 1000; ++i) {
            {
                std::lock_guard<std::mutex> lock(mutex_);
                if (arrived_.size() >= count) break;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        // Anything extra that was sent would be in the socket buffer by now.
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        stop();
        return arrived_;
    }
    void stop() {
        receiver_->stop();
        if (thread_.joinable()) thread_.join();
    }
    const net::UdpReceiverStats& stats() const { return receiver_->stats(); }

private:
    std::unique_ptr<net::UdpReceiver> receiver_;
    std::thread thread_;
    std::mutex mutex_;
    std::vector<Arrived> arrived_;
};

// Per destination port, the sequence of payloads must match the capture's (UDP on loopback
// keeps order per socket pair); returns the distinct source ports seen per socket.
void expect_identical(const std::vector<Sent>& sent, const std::vector<Arrived>& arrived,
                      const std::map<std::uint16_t, std::size_t>& socket_of_port) {
    ASSERT_EQ(arrived.size(), sent.size());
    std::map<std::size_t, std::vector<const Sent*>> expected;
    std::map<std::size_t, std::vector<const Arrived*>> got;
    for (const auto& s : sent) expected[socket_of_port.at(s.dst_port)].push_back(&s);
    for (const auto& a : arrived) got[a.socket_index].push_back(&a);
    for (const auto& [socket, list] : expected) {
        ASSERT_EQ(got[socket].size(), list.size()) << "socket " << socket;
        std::map<std::pair<std::uint32_t, std::uint16_t>, std::uint16_t> source_port_of;
        for (std::size_t i = 0; i < list.size(); ++i) {
            EXPECT_EQ(got[socket][i]->data, list[i]->data)
                << "datagram " << i << " on socket " << socket;
            // One sending socket per original sender, used consistently.
            auto [it, inserted] = source_port_of.emplace(
                std::make_pair(list[i]->src_ip, list[i]->src_port), got[socket][i]->src_port);
            EXPECT_EQ(it->second, got[socket][i]->src_port);
        }
    }
}

TEST(Replay, RealCaptureArrivesByteIdenticalThroughTheReceiver) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "OS-1-64_1024x10_fw20.pcap");
    const auto sent = read_capture(file);
    ASSERT_EQ(sent.size(), 75u);
    Listener listener(2);
    pcap::ReplayParams params;
    params.port_map = {{7502, listener.port(0)}, {7503, listener.port(1)}};
    params.rate = 2.0;
    const auto summary = pcap::replay_capture(file, params);
    EXPECT_EQ(summary.datagrams_sent, 75u);
    EXPECT_EQ(summary.send_errors, 0u);
    EXPECT_EQ(summary.passes, 1u);
    EXPECT_EQ(summary.source_sockets, 2u);  // lidar and IMU come from different sensor ports
    EXPECT_FALSE(summary.stopped);
    const auto arrived = listener.wait_for(75);
    expect_identical(sent, arrived, {{7502, 0}, {7503, 1}});
    EXPECT_EQ(listener.stats().kernel_drops.load(), 0u);
}

TEST(Replay, SensorsSharingAPortKeepDistinctSources) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "same_ports_legacy.pcap");
    const auto sent = read_capture(file);
    ASSERT_EQ(sent.size(), 2u);
    Listener listener(1);
    pcap::ReplayParams params;
    params.port_map = {{7502, listener.port(0)}};
    params.max_rate = true;
    const auto summary = pcap::replay_capture(file, params);
    EXPECT_EQ(summary.datagrams_sent, 2u);
    EXPECT_EQ(summary.bytes_sent, 12608u + 24896u);
    EXPECT_EQ(summary.reader_stats.reassembled, 2u);
    const auto arrived = listener.wait_for(2);
    expect_identical(sent, arrived, {{7502, 0}});
    ASSERT_EQ(arrived.size(), 2u);
    EXPECT_NE(arrived[0].src_port, arrived[1].src_port);
}

TEST(Replay, LoopsAndStops) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "duplicate_id.pcap");
    Listener listener(1);
    pcap::ReplayParams params;
    params.port_map = {{34636, listener.port(0)}};
    params.loop = true;
    params.max_passes = 5;
    params.rate = 1.0;  // one datagram per pass: 1 ms between passes
    const auto summary = pcap::replay_capture(file, params);
    EXPECT_EQ(summary.passes, 5u);
    EXPECT_EQ(summary.datagrams_sent, 5u);
    const auto arrived = listener.wait_for(5);
    ASSERT_EQ(arrived.size(), 5u);
    for (const auto& a : arrived) EXPECT_EQ(a.data.size(), 8448u);

    std::atomic<bool> stop{true};  // already set: nothing is sent
    params.stop = &stop;
    params.max_passes = 0;
    const auto stopped = pcap::replay_capture(file, params);
    EXPECT_TRUE(stopped.stopped);
    EXPECT_EQ(stopped.datagrams_sent, 0u);
}

TEST(Replay, LidarfuseReplayCommandSendsTheCapture) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "OS-1-64_1024x10_fw20.pcap");
    const auto sent = read_capture(file);
    Listener listener(2);
    const std::string command = test::tool_path() + " replay " + file.string() + " --to 127.0.0.1" +
                                " --port-map 7502:" + std::to_string(listener.port(0)) +
                                " --port-map 7503:" + std::to_string(listener.port(1)) +
                                " --rate 4";
    std::string output;
    ASSERT_EQ(test::run_command(command, &output), 0) << output;
    EXPECT_NE(output.find("replay_datagrams_sent 75 datagrams"), std::string::npos) << output;
    EXPECT_NE(output.find("replay_bytes_sent 807440 bytes"), std::string::npos) << output;
    EXPECT_NE(output.find("replay_send_errors 0 datagrams"), std::string::npos) << output;
    EXPECT_NE(output.find("replay_rate "), std::string::npos) << output;
    const auto arrived = listener.wait_for(75);
    expect_identical(sent, arrived, {{7502, 0}, {7503, 1}});
}

TEST(Replay, LidarfuseReplayRejectsBadArguments) {
    LIDARFUSE_REQUIRE_OUSTER_FILE(file, "duplicate_id.pcap");
    std::string output;
    for (const std::string args : {" --port-map 7502", " --port-map 7502:70000", " --rate 0",
                                   " --rate 2 --max-rate", " --passes 2"}) {
        output.clear();
        EXPECT_EQ(test::run_command(test::tool_path() + " replay " + file.string() + args, &output),
                  1)
            << args << ": " << output;
        EXPECT_NE(output.find("error"), std::string::npos) << output;
    }
    output.clear();
    EXPECT_EQ(test::run_command(test::tool_path() + " replay /nonexistent/x.pcap", &output), 1);
    EXPECT_NE(output.find("/nonexistent/x.pcap"), std::string::npos) << output;
}

}  // namespace
}  // namespace lidarfuse
