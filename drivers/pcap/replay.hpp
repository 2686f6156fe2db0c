#pragma once
// Sends the UDP datagrams of a capture to a host over real UDP sockets, so that a recorded
// session goes through the same receive path as live sensors (`lidarfuse replay`).
//
// Every UDP datagram of the capture is sent (lidar and IMU alike; reassembled first when it
// was IP-fragmented) to `host_ip` on its original destination port or the mapped one.
// Timing: datagram k leaves at start + (t_k - t_0) / rate on CLOCK_MONOTONIC, using absolute
// deadlines (clock_nanosleep TIMER_ABSTIME) so that errors do not accumulate; with
// `max_rate` no sleeping at all. Looping appends each pass after the previous one with one
// mean inter-datagram gap in between. Records whose capture time runs backwards are sent at
// once. One sending socket per original source (address, port) keeps sensors that shared a
// destination port apart at the receiver (by source port).
// Only `host_ip` is ever sent to; passes, duration and the stop flag bound the run.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "drivers/pcap/pcap_reader.hpp"

namespace lidarfuse::pcap {

struct ReplayParams {
    std::uint32_t host_ip = 0x7F000001u;              // 127.0.0.1, host byte order
    std::map<std::uint16_t, std::uint16_t> port_map;  // original dst port -> port sent to
    double rate = 1.0;             // capture-time speed factor: 2 = twice as fast as recorded
    bool max_rate = false;         // as fast as the socket takes them
    bool loop = false;             // start over at the end of the file
    std::uint64_t max_passes = 0;  // with loop: stop after this many passes (0 = no limit)
    double max_duration_s = 0.0;   // stop after this much wall time (0 = no limit)
    std::size_t max_source_sockets = 64;      // further sources share the last socket
    const std::atomic<bool>* stop = nullptr;  // optional: set from another thread or a signal
    PcapReaderParams reader;
    // Optional, called from the replaying thread after every 256th datagram sent: the pass
    // (from 0), datagrams sent so far (all passes) and bytes of the file read in this pass.
    std::function<void(std::uint64_t pass, std::uint64_t datagrams_sent, std::uint64_t bytes_read)>
        on_progress;
};

struct ReplaySummary {
    std::uint64_t datagrams_sent = 0;
    std::uint64_t bytes_sent = 0;  // UDP payload bytes
    std::uint64_t send_errors = 0;
    int first_send_errno = 0;
    std::uint64_t passes = 0;        // complete passes over the file
    std::size_t source_sockets = 0;  // distinct original sources seen
    double duration_s = 0.0;         // monotonic wall time of the whole run
    double capture_span_s = 0.0;     // capture time from first to last datagram of one pass
    bool stopped = false;            // ended by the stop flag or max_duration_s
    PcapReaderStats reader_stats;    // of the last pass (its files added up)
    std::string warning;             // the reader's warning (e.g. file cut off), if any

    double datagrams_per_s() const { return duration_s > 0 ? datagrams_sent / duration_s : 0.0; }
    double megabits_per_s() const { return duration_s > 0 ? bytes_sent * 8e-6 / duration_s : 0.0; }
};

// Replays `file`. Throws std::runtime_error / std::invalid_argument (naming the file) when it
// cannot be read or the parameters are invalid; send failures are counted, not thrown.
ReplaySummary replay_capture(const std::filesystem::path& file, const ReplayParams& params);

// Replays several files as one capture (a recording cut into files): one pass runs through
// them in order, on one time line (each datagram at its capture time after the pass's first).
// ReplaySummary::reader_stats add up the last pass's files; warning names its file.
ReplaySummary replay_capture(const std::vector<std::filesystem::path>& files,
                             const ReplayParams& params);

}  // namespace lidarfuse::pcap
