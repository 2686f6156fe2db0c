#include "bench/daemon_bench_replay.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <time.h>

#include "bench/dds_bench_reader.hpp"
#include "drivers/pcap/pcap_reader.hpp"

namespace lidarfuse::bench {

void replay(const std::filesystem::path& capture, std::vector<SensorReplay>* sensors) {
    pcap::PcapReader reader(capture);
    pcap::UdpDatagram d;
    std::int64_t start_ns = 0, first_capture_ns = 0;
    bool first = true;
    while (reader.next(&d)) {
        SensorReplay* s = nullptr;
        for (auto& candidate : *sensors) {
            if (candidate.capture_port == d.dst_port) s = &candidate;
        }
        if (!s) continue;
        if (first) {
            start_ns = monotonic_ns() + 20'000'000;
            first_capture_ns = d.timestamp_ns;
            first = false;
        }
        const std::int64_t deadline = start_ns + (d.timestamp_ns - first_capture_ns);
        timespec ts{static_cast<time_t>(deadline / 1'000'000'000),
                    static_cast<long>(deadline % 1'000'000'000)};
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
        sockaddr_in to{};
        to.sin_family = AF_INET;
        to.sin_port = htons(s->send_port);
        to.sin_addr.s_addr = htonl(0x7F000001u);
        ::sendto(s->socket, d.data, d.size, 0, reinterpret_cast<sockaddr*>(&to), sizeof(to));
        const std::int64_t sent = monotonic_ns();
        ++s->datagrams;
        if (d.size != s->format.lidar_packet_size()) continue;
        auto& scan = s->scans[s->format.frame_id(d.data)];
        scan.last_send_ns = sent;
        for (int c = 0; c < s->format.columns_per_packet(); ++c) {
            const std::uint8_t* col = s->format.column(d.data, c);
            if (!s->format.column_valid(col)) continue;
            const std::uint16_t mid = s->format.column_measurement_id(col);
            if (mid < scan.min_measurement_id) {
                scan.min_measurement_id = mid;
                scan.reference_ns = s->format.column_timestamp_ns(col);
            }
        }
    }
}

}  // namespace lidarfuse::bench
