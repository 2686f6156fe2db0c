// Live-path benchmark on loopback: 4 sensors' packet streams into 4 UdpReceivers (one
// socket and one receiving thread each), first as fast as the senders can go, then paced at
// the line rate of an OS1-64 in 1024x20 mode (64 packets per frame x 20 Hz = 1280 packets/s
// of 12,608 B per sensor). Prints `name value unit` lines: packets/s sustained, loss, kernel
// drops and receiver CPU per socket (getrusage RUSAGE_THREAD of the receiving thread over the
// phase, as % of one core) and datagrams read per wake-up. Each pair of phases runs with the
// receiver's default 32 MiB buffer request and with Linux's stock 208 KiB; the paced phase
// also with lidarfused's wait after a wake-up (network.receive_coalesce_ms, 5 ms).
//
// Usage: udp_loopback_bench [SECONDS_PER_PHASE=3]
// Payloads: the 64 lidar packets of OS-1-64_1024x10_fw20.pcap when the sample data is found
// ($LIDARFUSE_DATA_DIR or the build's default), else 64 synthetic 12,608 B packets.
// Note: on loopback the kernel's protocol processing runs in the *sender's* context, so the
// receiver's CPU is the recvmmsg copy, the cmsg parsing and the hand-off callback (a memcpy
// into a preallocated ring, as the daemon's ingest does). Senders, receivers and everything
// else on the machine share its cores: figures vary with load.
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <thread>
#include <vector>

#include "drivers/net/ipv4_address.hpp"
#include "drivers/net/udp_receiver.hpp"
#include "drivers/net/udp_sender.hpp"
#include "drivers/pcap/pcap_reader.hpp"

namespace {

using namespace lidarfuse;

constexpr int kSensors = 4;
constexpr double kLineRatePacketsPerS = 1280.0;  // OS1-64, 1024x20
constexpr std::size_t kRingSlots = 256;

std::int64_t monotonic_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

double thread_cpu_s() {
    rusage u{};
    getrusage(RUSAGE_THREAD, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

std::vector<std::vector<std::uint8_t>> load_packets() {
    std::vector<std::vector<std::uint8_t>> packets;
    const char* env = std::getenv("LIDARFUSE_DATA_DIR");
    const std::filesystem::path dir = (env && *env) ? env : LIDARFUSE_DEFAULT_DATA_DIR;
    const auto file = dir / "ouster" / "OS-1-64_1024x10_fw20.pcap";
    std::error_code ec;
    if (std::filesystem::exists(file, ec)) {
        pcap::PcapReader reader(file);
        pcap::UdpDatagram d;
        while (reader.next(&d)) {
            if (d.dst_port == 7502) packets.emplace_back(d.data, d.data + d.size);
        }
        std::printf("udp_loopback_payload_source 1 capture\n");
    }
    if (packets.empty()) {
        for (int i = 0; i < 64; ++i) packets.emplace_back(12608, static_cast<std::uint8_t>(i));
        std::printf("udp_loopback_payload_source 0 capture\n");
    }
    return packets;
}

struct PhaseResult {
    std::uint64_t sent = 0, received = 0, kernel_drops = 0, send_errors = 0, wakeups = 0;
    double seconds = 0;
    int rcvbuf_granted_bytes = 0;
    std::vector<double> receiver_cpu_s;
};

// paced_rate <= 0: as fast as possible. rcvbuf_bytes: receive buffer asked per socket;
// coalesce_us: the receivers' wait after a wake-up (UdpReceiverParams::coalesce_us).
PhaseResult run_phase(const std::vector<std::vector<std::uint8_t>>& packets, double seconds,
                      double paced_rate, int rcvbuf_bytes, int coalesce_us = 0) {
    std::vector<std::unique_ptr<net::UdpReceiver>> receivers;
    for (int s = 0; s < kSensors; ++s) {
        net::UdpReceiverParams p;
        p.bind_address = "127.0.0.1";
        p.ports = {0};
        p.requested_rcvbuf_bytes = rcvbuf_bytes;
        p.coalesce_us = coalesce_us;
        receivers.push_back(std::make_unique<net::UdpReceiver>(p));
    }
    PhaseResult result;
    result.rcvbuf_granted_bytes = receivers[0]->sockets()[0].granted_rcvbuf_bytes;
    result.receiver_cpu_s.assign(kSensors, 0.0);
    std::vector<std::thread> receiving;
    for (int s = 0; s < kSensors; ++s) {
        receiving.emplace_back([&, s] {
            // The hand-off ring a real ingest thread would copy into.
            std::vector<std::uint8_t> ring(kRingSlots * 65536);
            std::size_t slot = 0;
            const double cpu0 = thread_cpu_s();
            receivers[s]->run([&](const net::ReceivedDatagram& d) {
                std::memcpy(&ring[slot * 65536], d.data, d.size);
                slot = (slot + 1) % kRingSlots;
            });
            result.receiver_cpu_s[s] = thread_cpu_s() - cpu0;
        });
    }
    std::atomic<std::uint64_t> sent{0}, errors{0};
    std::vector<std::thread> senders;
    const std::int64_t start = monotonic_ns();
    const std::int64_t end = start + static_cast<std::int64_t>(seconds * 1e9);
    for (int s = 0; s < kSensors; ++s) {
        senders.emplace_back([&, s] {
            net::UdpSender sender;
            const std::uint16_t port = receivers[s]->sockets()[0].port;
            std::uint64_t n = 0, e = 0;
            const double interval_ns = paced_rate > 0 ? 1e9 / paced_rate : 0.0;
            for (std::uint64_t k = 0;; ++k) {
                if (paced_rate > 0) {
                    const std::int64_t deadline =
                        start + static_cast<std::int64_t>(k * interval_ns);
                    if (deadline >= end) break;
                    timespec ts{static_cast<time_t>(deadline / 1'000'000'000),
                                static_cast<long>(deadline % 1'000'000'000)};
                    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
                    }
                } else if ((k & 63) == 0 && monotonic_ns() >= end) {
                    break;
                }
                const auto& p = packets[k % packets.size()];
                if (sender.send_to(net::kLoopbackIpv4, port, p.data(), p.size()))
                    ++n;
                else
                    ++e;
            }
            sent += n;
            errors += e;
        });
    }
    for (auto& t : senders) t.join();
    result.seconds = static_cast<double>(monotonic_ns() - start) / 1e9;
    // Let the receivers drain what is queued, then stop them.
    std::uint64_t before = 0;
    for (int i = 0; i < 100; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        std::uint64_t now = 0;
        for (auto& r : receivers) now += r->stats().datagrams.load();
        if (now == before) break;
        before = now;
    }
    for (auto& r : receivers) r->stop();
    for (auto& t : receiving) t.join();
    result.sent = sent.load();
    result.send_errors = errors.load();
    for (auto& r : receivers) {
        result.received += r->stats().datagrams.load();
        result.kernel_drops += r->stats().kernel_drops.load();
        result.wakeups += r->stats().wakeups.load();
    }
    return result;
}

void report(const char* phase, const PhaseResult& r) {
    const double mean_cpu = [&] {
        double s = 0;
        for (double c : r.receiver_cpu_s) s += c;
        return s / r.receiver_cpu_s.size();
    }();
    const double max_cpu = *std::max_element(r.receiver_cpu_s.begin(), r.receiver_cpu_s.end());
    std::printf("udp_loopback_%s_seconds %.3f s\n", phase, r.seconds);
    std::printf("udp_loopback_%s_rcvbuf_granted %d bytes\n", phase, r.rcvbuf_granted_bytes);
    std::printf("udp_loopback_%s_sent_total %.0f packets/s\n", phase, r.sent / r.seconds);
    std::printf("udp_loopback_%s_received_total %.0f packets/s\n", phase, r.received / r.seconds);
    std::printf("udp_loopback_%s_received_per_sensor %.0f packets/s\n", phase,
                r.received / r.seconds / kSensors);
    std::printf("udp_loopback_%s_received_per_sensor_mbit %.1f Mbit/s\n", phase,
                r.received * 12608.0 * 8e-6 / r.seconds / kSensors);
    std::printf("udp_loopback_%s_loss %llu packets\n", phase,
                static_cast<unsigned long long>(r.sent - r.received));
    std::printf("udp_loopback_%s_loss_ratio %.6f fraction\n", phase,
                r.sent ? double(r.sent - r.received) / r.sent : 0.0);
    std::printf("udp_loopback_%s_kernel_drops %llu packets\n", phase,
                static_cast<unsigned long long>(r.kernel_drops));
    std::printf("udp_loopback_%s_send_errors %llu packets\n", phase,
                static_cast<unsigned long long>(r.send_errors));
    std::printf("udp_loopback_%s_receiver_cpu_mean %.2f %%core\n", phase,
                100.0 * mean_cpu / r.seconds);
    std::printf("udp_loopback_%s_receiver_cpu_max %.2f %%core\n", phase,
                100.0 * max_cpu / r.seconds);
    std::printf("udp_loopback_%s_receiver_cpu_per_packet %.2f us\n", phase,
                r.received ? 1e6 * mean_cpu * kSensors / r.received : 0.0);
    std::printf("udp_loopback_%s_datagrams_per_wakeup %.2f packets\n", phase,
                r.wakeups ? static_cast<double>(r.received) / r.wakeups : 0.0);
}

}  // namespace

int main(int argc, char** argv) {
    const double seconds = argc > 1 ? std::atof(argv[1]) : 3.0;
    if (!(seconds > 0)) {
        std::fprintf(stderr, "usage: udp_loopback_bench [SECONDS_PER_PHASE]\n");
        return 2;
    }
    const auto packets = load_packets();
    std::printf("udp_loopback_sensors %d sensors\n", kSensors);
    std::printf("udp_loopback_packet_size %zu bytes\n", packets[0].size());
    std::printf("udp_loopback_cores %u cores\n", std::thread::hardware_concurrency());
    constexpr int kLarge = 32 * 1024 * 1024;  // UdpReceiverParams default
    constexpr int kLinuxDefault = 212992;     // net.core.rmem_default on stock kernels
    report("maxrate", run_phase(packets, seconds, 0.0, kLarge));
    std::printf("udp_loopback_paced_target_per_sensor %.0f packets/s\n", kLineRatePacketsPerS);
    report("paced_1024x20", run_phase(packets, seconds, kLineRatePacketsPerS, kLarge));
    report("paced_1024x20_wait_5ms",
           run_phase(packets, seconds, kLineRatePacketsPerS, kLarge, 5000));
    // The same two with the kernel's default buffer, as an unprivileged process without a
    // raised net.core.rmem_max would get.
    report("maxrate_default_rcvbuf", run_phase(packets, seconds, 0.0, kLinuxDefault));
    report("paced_1024x20_default_rcvbuf",
           run_phase(packets, seconds, kLineRatePacketsPerS, kLinuxDefault));
    return 0;
}
