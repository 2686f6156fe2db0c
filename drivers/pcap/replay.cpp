#include "drivers/pcap/replay.hpp"

#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#include "drivers/net/udp_sender.hpp"

namespace lidarfuse::pcap {

namespace {

constexpr std::int64_t kNsPerS = 1'000'000'000;
constexpr std::int64_t kMaxSleepSliceNs = 100'000'000;  // re-check the stop flag this often

std::int64_t monotonic_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

bool stop_requested(const ReplayParams& p) {
    return p.stop && p.stop->load(std::memory_order_acquire);
}

// Sleeps until the absolute monotonic `deadline_ns`; false when stopped first.
bool sleep_until(std::int64_t deadline_ns, const ReplayParams& p) {
    for (;;) {
        if (stop_requested(p)) return false;
        const std::int64_t now = monotonic_ns();
        if (now >= deadline_ns) return true;
        const std::int64_t wake = std::min(deadline_ns, now + kMaxSleepSliceNs);
        timespec ts{static_cast<time_t>(wake / kNsPerS), static_cast<long>(wake % kNsPerS)};
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);  // EINTR: loop
    }
}

// One sending socket per original (source address, source port).
class SourceSockets {
public:
    explicit SourceSockets(std::size_t max_sockets) : max_(std::max<std::size_t>(max_sockets, 1)) {}

    net::UdpSender& for_source(std::uint32_t ip, std::uint16_t port) {
        const std::uint64_t key = (std::uint64_t{ip} << 16) | port;
        for (auto& [k, index] : keys_) {
            if (k == key) return *senders_[index];
        }
        if (senders_.size() < max_) senders_.push_back(std::make_unique<net::UdpSender>());
        keys_.emplace_back(key, senders_.size() - 1);
        return *senders_.back();
    }
    std::size_t sources() const { return keys_.size(); }

private:
    std::size_t max_;
    std::vector<std::pair<std::uint64_t, std::size_t>> keys_;
    std::vector<std::unique_ptr<net::UdpSender>> senders_;
};

}  // namespace

ReplaySummary replay_capture(const std::filesystem::path& file, const ReplayParams& params) {
    return replay_capture(std::vector<std::filesystem::path>{file}, params);
}

ReplaySummary replay_capture(const std::vector<std::filesystem::path>& files,
                             const ReplayParams& params) {
    const std::string name = files.empty() ? std::string("no file") : files.front().string();
    if (!params.max_rate && !(params.rate > 0.0 && std::isfinite(params.rate))) {
        throw std::invalid_argument("replay of " + name + ": rate must be > 0");
    }
    ReplaySummary summary;
    SourceSockets sockets(params.max_source_sockets);
    const std::int64_t start_ns = monotonic_ns();
    const std::int64_t end_ns =
        params.max_duration_s > 0
            ? start_ns + static_cast<std::int64_t>(params.max_duration_s * 1e9)
            : INT64_MAX;
    // Capture-time offset (ns, before dividing by rate) at which the current pass starts.
    double pass_offset_ns = 0.0;
    while (!files.empty()) {
        std::int64_t first_ts = 0, last_ts = 0;
        std::uint64_t in_pass = 0;
        summary.reader_stats = PcapReaderStats{};
        for (const auto& file : files) {
            PcapReader reader(file, params.reader);
            UdpDatagram d;
            while (reader.next(&d)) {
                if (in_pass == 0) first_ts = d.timestamp_ns;
                last_ts = std::max(last_ts, d.timestamp_ns);
                ++in_pass;
                if (!params.max_rate) {
                    const double offset_ns =
                        pass_offset_ns + static_cast<double>(d.timestamp_ns - first_ts);
                    const std::int64_t deadline =
                        start_ns + static_cast<std::int64_t>(offset_ns / params.rate);
                    if (deadline > end_ns || !sleep_until(deadline, params)) {
                        summary.stopped = true;
                        break;
                    }
                } else if (stop_requested(params) ||
                           (params.max_duration_s > 0 && monotonic_ns() >= end_ns)) {
                    summary.stopped = true;
                    break;
                }
                const auto mapped = params.port_map.find(d.dst_port);
                const std::uint16_t port =
                    mapped == params.port_map.end() ? d.dst_port : mapped->second;
                auto& sender = sockets.for_source(d.src_ip, d.src_port);
                if (sender.send_to(params.host_ip, port, d.data, d.size)) {
                    ++summary.datagrams_sent;
                    summary.bytes_sent += d.size;
                    if (params.on_progress && summary.datagrams_sent % 256 == 0) {
                        params.on_progress(summary.passes, summary.datagrams_sent,
                                           summary.reader_stats.bytes_read +  // earlier files
                                               reader.stats().bytes_read);
                    }
                } else {
                    if (summary.send_errors++ == 0) summary.first_send_errno = sender.last_errno();
                }
            }
            summary.reader_stats += reader.stats();
            if (!reader.warning().empty()) summary.warning = reader.warning();  // names the file
            if (summary.stopped) break;
        }
        if (summary.stopped) break;
        ++summary.passes;
        const std::int64_t span_ns = in_pass > 0 ? last_ts - first_ts : 0;
        summary.capture_span_s = static_cast<double>(span_ns) / 1e9;
        if (!params.loop || in_pass == 0) break;
        if (params.max_passes > 0 && summary.passes >= params.max_passes) break;
        // One mean gap between passes; 1 ms when the pass has no time extent at all.
        const double gap_ns = span_ns > 0
                                  ? static_cast<double>(span_ns) /
                                        static_cast<double>(std::max<std::uint64_t>(in_pass - 1, 1))
                                  : 1e6;
        pass_offset_ns += static_cast<double>(span_ns) + gap_ns;
    }
    summary.source_sockets = sockets.sources();
    summary.duration_s = static_cast<double>(monotonic_ns() - start_ns) / 1e9;
    return summary;
}

}  // namespace lidarfuse::pcap
