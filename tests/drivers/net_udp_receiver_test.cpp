// UdpReceiver on loopback (127.0.0.1, ephemeral ports only): payloads and sources arrive
// intact, senders sharing a port are told apart, truncation is counted, stop() wakes the loop,
// datagrams arriving during the wait after a wake-up are read together, and of the receive
// ring only what datagrams fill becomes resident.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <fstream>
#include <future>
#include <map>
#include <thread>
#include <vector>

#include "drivers/net/ipv4_address.hpp"
#include "drivers/net/udp_receiver.hpp"
#include "drivers/net/udp_sender.hpp"

namespace lidarfuse::net {
namespace {

struct Got {
    std::uint32_t src_ip;
    std::uint16_t src_port;
    std::uint16_t local_port;
    std::size_t socket_index;
    std::int64_t receive_time_ns;
    std::vector<std::uint8_t> data;
};

std::vector<std::uint8_t> payload(std::size_t size, std::uint32_t tag) {
    std::vector<std::uint8_t> out(size);
    for (std::size_t i = 0; i < size; ++i) out[i] = static_cast<std::uint8_t>(tag * 7 + i * 3);
    if (size >= 4) std::memcpy(out.data(), &tag, 4);
    return out;
}

UdpReceiverParams loopback_params(std::size_t ports) {
    UdpReceiverParams p;
    p.bind_address = "127.0.0.1";
    p.ports.assign(ports, 0);
    return p;
}

// Polls until `count` datagrams arrived or 200 polls of 50 ms passed (data already in the
// socket buffer arrives on the first poll; this bound only keeps a broken build from hanging).
std::vector<Got> receive(UdpReceiver& receiver, std::size_t count) {
    std::vector<Got> got;
    for (int i = 0; i < 200 && got.size() < count; ++i) {
        receiver.poll_once(50, [&](const ReceivedDatagram& d) {
            got.push_back({d.src_ip, d.src_port, d.local_port, d.socket_index, d.receive_time_ns,
                           std::vector<std::uint8_t>(d.data, d.data + d.size)});
        });
    }
    return got;
}

TEST(UdpReceiver, ReceivesEveryDatagramWithPayloadAndSource) {
    UdpReceiverParams params = loopback_params(1);
    params.batch_size = 8;  // several recvmmsg rounds per wake-up
    UdpReceiver receiver(params);
    ASSERT_EQ(receiver.sockets().size(), 1u);
    const std::uint16_t port = receiver.sockets()[0].port;
    EXPECT_NE(port, 0);
    EXPECT_GT(receiver.sockets()[0].granted_rcvbuf_bytes, 0);

    UdpSender sender({"127.0.0.1", 0});
    constexpr int kCount = 100;
    std::vector<Got> got;
    for (int i = 0; i < kCount; ++i) {
        const auto data = payload(i % 5 == 0 ? 12608 : 48 + i, static_cast<std::uint32_t>(i));
        ASSERT_TRUE(sender.send_to(kLoopbackIpv4, port, data.data(), data.size()));
        // Receive after every ten sends, so that even a small rmem_max cannot drop any.
        if (i % 10 == 9) {
            const auto part = receive(receiver, 10);
            got.insert(got.end(), part.begin(), part.end());
        }
    }
    ASSERT_EQ(got.size(), static_cast<std::size_t>(kCount));
    for (int i = 0; i < kCount; ++i) {
        EXPECT_EQ(got[i].data, payload(i % 5 == 0 ? 12608 : 48 + i, static_cast<std::uint32_t>(i)));
        EXPECT_EQ(got[i].src_ip, kLoopbackIpv4);
        EXPECT_EQ(got[i].src_port, sender.local_port());
        EXPECT_EQ(got[i].local_port, port);
        EXPECT_GT(got[i].receive_time_ns, 1'500'000'000'000'000'000LL);  // a kernel wall time
    }
    const auto& s = receiver.stats();
    EXPECT_EQ(s.datagrams.load(), static_cast<std::uint64_t>(kCount));
    EXPECT_EQ(s.truncated.load(), 0u);
    EXPECT_EQ(s.kernel_drops.load(), 0u);
    EXPECT_EQ(s.errors.load(), 0u);
}

TEST(UdpReceiver, TwoSendersOnOnePortAreToldApartBySource) {
    UdpReceiver receiver(loopback_params(2));
    const std::uint16_t port = receiver.sockets()[1].port;
    UdpSender a({"127.0.0.1", 0});
    UdpSender b({"127.0.0.2", 0});  // all of 127/8 is loopback on Linux
    for (std::uint32_t i = 0; i < 20; ++i) {
        const auto data = payload(100, i);
        ASSERT_TRUE((i % 2 ? b : a).send_to(kLoopbackIpv4, port, data.data(), data.size()));
    }
    const auto got = receive(receiver, 20);
    ASSERT_EQ(got.size(), 20u);
    for (std::uint32_t i = 0; i < 20; ++i) {
        EXPECT_EQ(got[i].socket_index, 1u);
        EXPECT_EQ(got[i].data, payload(100, i));
        if (i % 2) {
            EXPECT_EQ(got[i].src_ip, 0x7F000002u);
            EXPECT_EQ(got[i].src_port, b.local_port());
        } else {
            EXPECT_EQ(got[i].src_ip, 0x7F000001u);
            EXPECT_EQ(got[i].src_port, a.local_port());
        }
    }
}

TEST(UdpReceiver, SeveralPortsInOneReceiver) {
    UdpReceiver receiver(loopback_params(3));
    UdpSender sender({"127.0.0.1", 0});
    for (std::size_t s = 0; s < 3; ++s) {
        const auto data = payload(64, static_cast<std::uint32_t>(s));
        ASSERT_TRUE(
            sender.send_to(kLoopbackIpv4, receiver.sockets()[s].port, data.data(), data.size()));
    }
    auto got = receive(receiver, 3);
    ASSERT_EQ(got.size(), 3u);
    std::map<std::size_t, std::vector<std::uint8_t>> by_socket;
    for (const auto& g : got) {
        EXPECT_EQ(g.local_port, receiver.sockets()[g.socket_index].port);
        by_socket[g.socket_index] = g.data;
    }
    for (std::size_t s = 0; s < 3; ++s)
        EXPECT_EQ(by_socket[s], payload(64, static_cast<std::uint32_t>(s)));
}

TEST(UdpReceiver, OversizedDatagramIsCountedAsTruncatedAndNotDelivered) {
    UdpReceiverParams params = loopback_params(1);
    params.max_datagram_bytes = 1024;
    UdpReceiver receiver(params);
    UdpSender sender({"127.0.0.1", 0});
    const auto big = payload(2000, 1), ok = payload(1024, 2);
    ASSERT_TRUE(sender.send_to(kLoopbackIpv4, receiver.sockets()[0].port, big.data(), big.size()));
    ASSERT_TRUE(sender.send_to(kLoopbackIpv4, receiver.sockets()[0].port, ok.data(), ok.size()));
    const auto got = receive(receiver, 1);
    ASSERT_EQ(got.size(), 1u);
    EXPECT_EQ(got[0].data, ok);
    EXPECT_EQ(receiver.stats().truncated.load(), 1u);
    EXPECT_EQ(receiver.stats().datagrams.load(), 1u);
}

// Sends `count` copies of `data` to the receiver's first socket.
void send_burst(UdpSender& sender, const UdpReceiver& receiver,
                const std::vector<std::uint8_t>& data, int count) {
    for (int i = 0; i < count; ++i) {
        ASSERT_TRUE(
            sender.send_to(kLoopbackIpv4, receiver.sockets()[0].port, data.data(), data.size()));
    }
}

TEST(UdpReceiver, KernelDropsAreCounted) {
    UdpReceiverParams params = loopback_params(1);
    params.requested_rcvbuf_bytes = 4096;  // the kernel's minimum: a few datagrams at most
    UdpReceiver receiver(params);
    UdpSender sender({"127.0.0.1", 0});
    const auto data = payload(1400, 0);
    ASSERT_NO_FATAL_FAILURE(send_burst(sender, receiver, data, 200));
    const auto got = receive(receiver, 1);
    ASSERT_GE(got.size(), 1u);
    // The drop count rides on the next datagram that gets through.
    ASSERT_TRUE(
        sender.send_to(kLoopbackIpv4, receiver.sockets()[0].port, data.data(), data.size()));
    const auto more = receive(receiver, 1);
    ASSERT_EQ(more.size(), 1u);
    EXPECT_GT(receiver.stats().kernel_drops.load(), 0u);
    EXPECT_EQ(receiver.stats().kernel_drops.load() + got.size() + more.size(), 201u);
}

TEST(UdpReceiver, KernelDropsAfterTheLastDatagramShowWhenIdle) {
    UdpReceiverParams params = loopback_params(1);
    params.requested_rcvbuf_bytes = 4096;
    UdpReceiver receiver(params);
    UdpSender sender({"127.0.0.1", 0});
    const auto data = payload(1400, 0);
    ASSERT_NO_FATAL_FAILURE(send_burst(sender, receiver, data, 200));
    // Nothing follows the burst: no later datagram carries the count, the idle poll reads it.
    const auto got = receive(receiver, 1);  // the first poll drains all that was kept
    ASSERT_GE(got.size(), 1u);
    ASSERT_LT(got.size(), 200u);
    EXPECT_EQ(receiver.stats().kernel_drops.load(), 0u);
    receiver.poll_once(10, [](const ReceivedDatagram&) { FAIL() << "nothing was sent"; });
    EXPECT_EQ(receiver.stats().kernel_drops.load() + got.size(), 200u);
}

TEST(UdpReceiver, StopWakesABlockedLoopAtOnce) {
    UdpReceiverParams params = loopback_params(1);
    params.poll_timeout_ms = -1;  // only stop() can end the poll
    UdpReceiver receiver(params);
    std::promise<void> started;
    auto running = std::async(std::launch::async, [&] {
        started.set_value();
        receiver.run([](const ReceivedDatagram&) {});
    });
    started.get_future().wait();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_EQ(running.wait_for(std::chrono::milliseconds(0)), std::future_status::timeout);
    receiver.stop();
    // Generous bound: a missing wake-up would block forever, not for 10 s.
    EXPECT_EQ(running.wait_for(std::chrono::seconds(10)), std::future_status::ready);
    EXPECT_TRUE(receiver.stopped());
    EXPECT_EQ(receiver.poll_once(-1, [](const ReceivedDatagram&) {}), 0u);
}

// run() on its own thread, receiving datagrams that a sender spreads over time: after the
// first, `spaced` more, `gap` apart. Returns the receiver's wake-ups with work.
std::uint64_t wakeups_for_spaced_datagrams(int coalesce_us, int spaced,
                                           std::chrono::milliseconds gap) {
    UdpReceiverParams params = loopback_params(1);
    params.coalesce_us = coalesce_us;
    UdpReceiver receiver(params);
    std::atomic<int> received{0};
    auto running = std::async(std::launch::async, [&] {
        receiver.run([&](const ReceivedDatagram&) { received.fetch_add(1); });
    });
    UdpSender sender({"127.0.0.1", 0});
    const auto data = payload(64, 1);
    const auto send = [&] {
        EXPECT_TRUE(
            sender.send_to(kLoopbackIpv4, receiver.sockets()[0].port, data.data(), data.size()));
    };
    const auto wait_for = [&](int count) {
        // Generous bound: a lost datagram would wait forever, not for 10 s.
        for (int i = 0; i < 10'000 && received.load() < count; ++i)
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
    };
    send();
    wait_for(1);  // the first wake-up has begun: its wait starts now
    for (int i = 0; i < spaced; ++i) {
        std::this_thread::sleep_for(gap);
        send();
    }
    wait_for(1 + spaced);
    receiver.stop();
    running.wait();
    EXPECT_EQ(received.load(), 1 + spaced);
    return receiver.stats().wakeups.load();
}

// What arrives while a receiver waits after a wake-up is read in one batch: nine datagrams
// 2 ms apart make one more wake-up, not nine, within a wait of 2 s.
TEST(UdpReceiver, DatagramsArrivingDuringTheWaitAreReadInOneWakeUp) {
    EXPECT_EQ(wakeups_for_spaced_datagrams(2'000'000, 9, std::chrono::milliseconds(2)), 2u);
}

// The control: without the wait, each datagram that arrives into an empty socket wakes the
// receiver (40 ms apart, so even a loaded machine reads most of them one by one).
TEST(UdpReceiver, WithoutTheWaitEachSpacedDatagramWakesTheReceiver) {
    EXPECT_GE(wakeups_for_spaced_datagrams(0, 9, std::chrono::milliseconds(40)), 5u);
}

// A receiver with a 64 KiB buffer request and a 2 s wait, run() on its own thread, handed a
// burst of three datagrams of `burst_bytes` each (all three fit in the buffer) before it
// starts, then one small datagram; stopped once all four are in. Returns the wake-ups not
// followed by the wait.
std::uint64_t waits_skipped_after_burst(std::size_t burst_bytes) {
    UdpReceiverParams params = loopback_params(1);
    params.requested_rcvbuf_bytes = 65536;
    params.coalesce_us = 2'000'000;
    UdpReceiver receiver(params);
    EXPECT_LE(receiver.sockets()[0].granted_rcvbuf_bytes, 4 * 60'000);  // 60 kB are > 1/4
    UdpSender sender({"127.0.0.1", 0});
    const std::uint16_t port = receiver.sockets()[0].port;
    const auto big = payload(burst_bytes, 1), small = payload(64, 2);
    for (int i = 0; i < 3; ++i)
        EXPECT_TRUE(sender.send_to(kLoopbackIpv4, port, big.data(), big.size()));
    std::atomic<int> received{0};
    auto running = std::async(std::launch::async, [&] {
        receiver.run([&](const ReceivedDatagram&) { received.fetch_add(1); });
    });
    const auto wait_for = [&](int count) {
        for (int i = 0; i < 10'000 && received.load() < count; ++i)
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
    };
    wait_for(3);
    EXPECT_TRUE(sender.send_to(kLoopbackIpv4, port, small.data(), small.size()));
    wait_for(4);
    receiver.stop();
    running.wait();
    EXPECT_EQ(received.load(), 4);
    return receiver.stats().waits_skipped.load();
}

// A wake-up that read a quarter of the receive buffer or more polls again at once: waiting
// then could let a fast stream overflow a small buffer. The small datagram's wake-up waits.
TEST(UdpReceiver, AWakeUpThatReadAQuarterOfTheBufferIsNotFollowedByTheWait) {
    EXPECT_EQ(waits_skipped_after_burst(20'000), 1u);
}

// The control: the same burst of small datagrams is followed by the wait.
TEST(UdpReceiver, AWakeUpThatReadLittleIsFollowedByTheWait) {
    EXPECT_EQ(waits_skipped_after_burst(64), 0u);
}

TEST(UdpReceiver, StopEndsTheWaitAfterAWakeUpAtOnce) {
    UdpReceiverParams params = loopback_params(1);
    params.coalesce_us = 10'000'000;  // the longest allowed
    UdpReceiver receiver(params);
    std::promise<void> woke;
    auto running = std::async(std::launch::async, [&] {
        receiver.run([&](const ReceivedDatagram&) { woke.set_value(); });
    });
    UdpSender sender({"127.0.0.1", 0});
    const auto data = payload(64, 1);
    ASSERT_TRUE(
        sender.send_to(kLoopbackIpv4, receiver.sockets()[0].port, data.data(), data.size()));
    woke.get_future().wait();
    receiver.stop();
    // Well within the 10 s wait: stop() must end it, not the wait's end.
    EXPECT_EQ(running.wait_for(std::chrono::seconds(5)), std::future_status::ready);
    running.wait();
}

// The process's resident set (bytes), from /proc/self/statm.
std::size_t resident_bytes() {
    std::ifstream statm("/proc/self/statm");
    std::size_t pages_total = 0, pages_resident = 0;
    statm >> pages_total >> pages_resident;
    return pages_resident * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

// A receiver per sensor port holds batch_size slots of max_datagram_bytes; only the bytes the
// kernel writes may become resident. Here the ring is 64 x 64 KiB = 4 MiB and 64 datagrams
// of 1,000 bytes touch at most 64 pages of it (256 KiB), so the process must grow by well
// under 1 MiB; a ring filled on construction would add the whole 4 MiB.
TEST(UdpReceiver, OnlyTheBytesDatagramsFillAreResident) {
    UdpReceiverParams params = loopback_params(1);
    params.batch_size = 64;
    params.max_datagram_bytes = 65536;
    constexpr std::size_t kMiB = std::size_t{1} << 20;
    const std::size_t before = resident_bytes();
    UdpReceiver receiver(params);
    UdpSender sender({"127.0.0.1", 0});
    constexpr std::size_t kDatagrams = 64;
    for (std::uint32_t i = 0; i < kDatagrams; ++i) {
        const auto data = payload(1000, i);
        ASSERT_TRUE(
            sender.send_to(kLoopbackIpv4, receiver.sockets()[0].port, data.data(), data.size()));
    }
    const auto got = receive(receiver, kDatagrams);
    ASSERT_EQ(got.size(), kDatagrams);
    for (const auto& g : got) EXPECT_EQ(g.data.size(), 1000u);
    const std::size_t after = resident_bytes();
    const std::size_t grown = after - std::min(before, after);
    EXPECT_LT(grown, kMiB) << "the receive ring became resident beyond what was received";
}

TEST(UdpReceiver, AWaitOutsideItsRangeIsRefused) {
    UdpReceiverParams params = loopback_params(1);
    params.coalesce_us = -1;
    EXPECT_THROW(UdpReceiver{params}, std::runtime_error);
    params.coalesce_us = 10'000'001;
    EXPECT_THROW(UdpReceiver{params}, std::runtime_error);
}

TEST(UdpReceiver, BindFailuresListEveryPort) {
    UdpReceiver first(loopback_params(2));
    UdpReceiverParams params;
    params.bind_address = "127.0.0.1";
    params.ports = {first.sockets()[0].port, first.sockets()[1].port};
    try {
        UdpReceiver second(params);
        FAIL() << "ports in use were bound twice";
    } catch (const std::runtime_error& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find(":" + std::to_string(params.ports[0])), std::string::npos) << what;
        EXPECT_NE(what.find(":" + std::to_string(params.ports[1])), std::string::npos) << what;
    }
    params.bind_address = "not-an-address";
    EXPECT_THROW(UdpReceiver bad(params), std::invalid_argument);
}

}  // namespace
}  // namespace lidarfuse::net
