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

// One replay run: sends each pass over the files at capture timing (or as fast as it can),
// until the files end, the passes or the duration are used up, or the stop flag is set.
class Replayer {
public:
    explicit Replayer(const ReplayParams& params)
        : params_(params),
          sockets_(params.max_source_sockets),
          start_ns_(monotonic_ns()),
          end_ns_(params.max_duration_s > 0
                      ? start_ns_ + static_cast<std::int64_t>(params.max_duration_s * 1e9)
                      : INT64_MAX) {}

    ReplaySummary run(const std::vector<std::filesystem::path>& files) {
        while (!files.empty()) {
            if (!replay_pass(files)) break;
            if (!end_pass()) break;
        }
        summary_.source_sockets = sockets_.sources();
        summary_.duration_s = static_cast<double>(monotonic_ns() - start_ns_) / 1e9;
        return summary_;
    }

private:
    // One pass over the files, in order; false when stopped.
    bool replay_pass(const std::vector<std::filesystem::path>& files) {
        first_ts_ = 0;
        last_ts_ = 0;
        in_pass_ = 0;
        summary_.reader_stats = PcapReaderStats{};
        for (const auto& file : files) {
            PcapReader reader(file, params_.reader);
            replay_file(&reader);
            summary_.reader_stats += reader.stats();
            if (!reader.warning().empty()) summary_.warning = reader.warning();  // names the file
            if (summary_.stopped) return false;
        }
        return true;
    }

    void replay_file(PcapReader* reader) {
        UdpDatagram d;
        while (reader->next(&d)) {
            if (in_pass_ == 0) first_ts_ = d.timestamp_ns;
            last_ts_ = std::max(last_ts_, d.timestamp_ns);
            ++in_pass_;
            if (!wait_until_due(d)) {
                summary_.stopped = true;
                break;
            }
            send(d, reader->stats().bytes_read);
        }
    }

    // Waits until the datagram is due (capture time since the pass's first datagram, divided
    // by the rate); false when the stop flag or the end of the duration comes first.
    bool wait_until_due(const UdpDatagram& d) const {
        if (!params_.max_rate) {
            const double offset_ns =
                pass_offset_ns_ + static_cast<double>(d.timestamp_ns - first_ts_);
            const std::int64_t deadline =
                start_ns_ + static_cast<std::int64_t>(offset_ns / params_.rate);
            return !(deadline > end_ns_ || !sleep_until(deadline, params_));
        }
        return !(stop_requested(params_) ||
                 (params_.max_duration_s > 0 && monotonic_ns() >= end_ns_));
    }

    // To host_ip on the (mapped) destination port, from the socket of the original source.
    void send(const UdpDatagram& d, std::uint64_t file_bytes_read) {
        const auto mapped = params_.port_map.find(d.dst_port);
        const std::uint16_t port = mapped == params_.port_map.end() ? d.dst_port : mapped->second;
        auto& sender = sockets_.for_source(d.src_ip, d.src_port);
        if (sender.send_to(params_.host_ip, port, d.data, d.size)) {
            ++summary_.datagrams_sent;
            summary_.bytes_sent += d.size;
            if (params_.on_progress && summary_.datagrams_sent % 256 == 0) {
                params_.on_progress(summary_.passes, summary_.datagrams_sent,
                                    summary_.reader_stats.bytes_read +  // earlier files
                                        file_bytes_read);
            }
        } else {
            if (summary_.send_errors++ == 0) summary_.first_send_errno = sender.last_errno();
        }
    }

    // Counts a complete pass; false when no further pass is wanted.
    bool end_pass() {
        ++summary_.passes;
        const std::int64_t span_ns = in_pass_ > 0 ? last_ts_ - first_ts_ : 0;
        summary_.capture_span_s = static_cast<double>(span_ns) / 1e9;
        if (!params_.loop || in_pass_ == 0) return false;
        if (params_.max_passes > 0 && summary_.passes >= params_.max_passes) return false;
        // One mean gap between passes; 1 ms when the pass has no time extent at all.
        const double gap_ns =
            span_ns > 0 ? static_cast<double>(span_ns) /
                              static_cast<double>(std::max<std::uint64_t>(in_pass_ - 1, 1))
                        : 1e6;
        pass_offset_ns_ += static_cast<double>(span_ns) + gap_ns;
        return true;
    }

    const ReplayParams& params_;
    SourceSockets sockets_;
    ReplaySummary summary_;
    const std::int64_t start_ns_;  // monotonic
    const std::int64_t end_ns_;    // monotonic; INT64_MAX: no duration limit
    // Capture-time offset (ns, before dividing by rate) at which the current pass starts.
    double pass_offset_ns_ = 0.0;
    std::int64_t first_ts_ = 0, last_ts_ = 0;  // capture time of the pass, ns
    std::uint64_t in_pass_ = 0;                // datagrams read in the pass
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
    return Replayer(params).run(files);
}

}  // namespace lidarfuse::pcap
