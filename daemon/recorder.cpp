#include "daemon/recorder.hpp"

#include <pcap/pcap.h>
#include <pthread.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <ctime>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <vector>

#include "daemon/sensor_ingest.hpp"
#include "drivers/io/cloud_file_support.hpp"
#include "drivers/pcap/udp_frame_builder.hpp"

namespace lidarfuse::daemon {

namespace fs = std::filesystem;

namespace {

constexpr double kBytesPerMb = 1024.0 * 1024.0;
// Larger than any Ethernet frame of one whole UDP datagram (65,507 + 42 bytes).
constexpr int kSnapLength = 262144;
// How often the writer looks at the free space.
constexpr auto kCheckPeriod = std::chrono::seconds(1);
// How long a datagram may wait in the ring for the writer (when the ring is less than an
// eighth full).
constexpr auto kDrainPeriod = std::chrono::milliseconds(20);
// The part of the ring used while the writer keeps up (a quarter second of 4 OS1-64): its
// pages stay resident, the rest of the ring is touched only by a backlog.
constexpr std::size_t kWarmRingBytes = 16u << 20;
// stdio's buffer of a pcap file: a write(2) per 80 OS1-64 datagrams, not per datagram.
constexpr std::size_t kFileBufferBytes = 1 << 20;

// "20261124T153303Z" for ns since the Unix epoch.
std::string utc_stamp(std::int64_t ns) {
    const std::time_t seconds = static_cast<std::time_t>(ns / 1'000'000'000);
    std::tm tm{};
    ::gmtime_r(&seconds, &tm);
    char text[32];
    std::strftime(text, sizeof text, "%Y%m%dT%H%M%SZ", &tm);
    return text;
}

std::uint64_t filesystem_free_bytes(const fs::path& path) {
    std::error_code error;
    const auto space = fs::space(path, error);
    return error ? 0 : space.available;
}

// A datagram in the ring: this header, then its payload, padded to 8 bytes.
struct RecordHeader {
    std::uint32_t size;  // payload bytes; kWrap: the rest of the ring is unused, go on at 0
    std::uint32_t src_ip;
    std::uint16_t src_port;
    std::uint16_t dst_port;
    std::uint32_t reserved;
    std::int64_t receive_time_ns;
};
constexpr std::uint32_t kWrap = 0xFFFFFFFFu;

std::size_t record_bytes(std::size_t payload) {
    return (sizeof(RecordHeader) + payload + 7) & ~std::size_t{7};
}

}  // namespace

// The ring: many receiver threads write (under the mutex, which they hold only for a copy),
// the writer thread reads the oldest record without it (producers never write into the
// bytes between tail and head) and frees it under the mutex when it is on disk.
struct Recorder::Impl {
    RecordConfig config;
    std::uint32_t dst_ip = 0;
    std::shared_ptr<spdlog::logger> log;
    FreeSpace free_space;
    fs::path folder;

    mutable std::mutex mutex;
    std::condition_variable wake;
    // Not initialised (unlike a vector's): a page becomes resident only when the head first
    // reaches it (see kWarmRingBytes).
    struct Bytes {
        std::unique_ptr<std::uint8_t[]> bytes;
        std::size_t count = 0;
        std::uint8_t* data() { return bytes.get(); }
        std::size_t size() const { return count; }
    } ring;
    std::size_t head = 0, tail = 0, used = 0;  // used counts wrapped-over bytes too
    bool stopping = false;
    RecorderStats stats;  // under mutex

    std::thread writer;
    // Writer thread only.
    pcap_t* pcap = nullptr;
    pcap_dumper_t* dumper = nullptr;
    fs::path file;
    std::vector<fs::path> files;  // of this recording, oldest first, the open one last
    std::uint64_t file_bytes = 0;
    std::int64_t file_first_ns = 0;
    std::uint16_t ip_id = 1;
    std::size_t next_sequence = 0;
    std::vector<std::vector<std::uint8_t>> frames;
    bool failed = false;

    void run();
    bool write_record(const RecordHeader& h, const std::uint8_t* payload);  // false: not written
    void open_file(std::int64_t first_ns);
    void close_file();
    void check_free_space();
    void stop_recording(const std::string& why);
};

Recorder::Recorder(const RecordConfig& config, const station::StationConfig& station,
                   std::uint32_t dst_ip, std::shared_ptr<spdlog::logger> log, FreeSpace free_space)
    : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.config = config;
    m.dst_ip = dst_ip;
    m.log = std::move(log);
    m.free_space = free_space ? std::move(free_space) : FreeSpace(filesystem_free_bytes);
    folder_ = config.directory / utc_stamp(realtime_ns());
    for (int k = 2; fs::exists(folder_); ++k) {  // two starts within a second
        folder_ = config.directory / (utc_stamp(realtime_ns()) + "-" + std::to_string(k));
    }
    m.folder = folder_;
    std::error_code error;
    fs::create_directories(folder_ / "metadata", error);
    if (error) {
        throw std::runtime_error("output.record.directory: cannot create " + folder_.string() +
                                 ": " + error.message());
    }
    // The snapshot: what a later run needs to read the packets the way this one did.
    if (!station.source_file.empty())
        fs::copy_file(station.source_file, folder_ / "station.yaml", error);
    if (error)
        throw std::runtime_error("output.record: cannot copy " + station.source_file.string() +
                                 " into " + folder_.string() + ": " + error.message());
    for (const auto& sensor : station.sensors) {
        if (!sensor.enabled || sensor.metadata.empty()) continue;
        fs::copy_file(sensor.metadata, folder_ / "metadata" / (sensor.name + ".json"), error);
        if (error)
            throw std::runtime_error("output.record: cannot copy " + sensor.metadata.string() +
                                     " into " + folder_.string() + ": " + error.message());
    }
    m.ring.count = static_cast<std::size_t>(config.queue_mb * kBytesPerMb) & ~std::size_t{7};
    m.ring.bytes.reset(new std::uint8_t[m.ring.count]);  // default-initialised: untouched
    m.stats.enabled = true;
    m.stats.recording = true;
    m.stats.folder = folder_.string();
    m.writer = std::thread([&m] {
        ::pthread_setname_np(::pthread_self(), "lf-record");
        m.run();
    });
}

Recorder::~Recorder() { stop(); }

void Recorder::offer(const net::ReceivedDatagram& d) {
    Impl& m = *impl_;
    const std::size_t need = record_bytes(d.size);
    const std::size_t capacity = m.ring.size();
    std::lock_guard<std::mutex> lock(m.mutex);
    if (!m.stats.recording) return;
    if (m.used == 0) m.head = m.tail = 0;
    const bool full = m.used > 0 && m.head == m.tail;
    std::size_t at = capacity;  // capacity: no room
    std::size_t wasted = 0;
    if (!full && m.head >= m.tail) {  // free: [head, capacity) and [0, tail)
        // Back to the start as soon as the writer has freed it and the head is past the
        // first kWarmRingBytes: the ring reaches further only while the disk lags behind.
        const bool early_wrap = m.head >= kWarmRingBytes && m.tail >= need;
        if (capacity - m.head >= need && !early_wrap) {
            at = m.head;
        } else if (m.tail >= need) {  // wrap: the end of the ring stays unused
            wasted = capacity - m.head;
            at = 0;
        }
    } else if (!full && m.tail - m.head >= need) {  // free: [head, tail)
        at = m.head;
    }
    if (at == capacity) {
        ++m.stats.queue_drops;
        return;
    }
    if (wasted > 0) {
        RecordHeader wrap{};
        wrap.size = kWrap;
        std::memcpy(m.ring.data() + m.head, &wrap, std::min(wasted, sizeof wrap));
    }
    RecordHeader h{static_cast<std::uint32_t>(d.size),
                   d.src_ip,
                   d.src_port,
                   d.local_port,
                   0,
                   d.receive_time_ns};
    std::memcpy(m.ring.data() + at, &h, sizeof h);
    std::memcpy(m.ring.data() + at + sizeof h, d.data, d.size);
    m.head = at + need;
    const std::size_t before = m.used;
    m.used += need + wasted;
    if (before < capacity / 8 && m.used >= capacity / 8) m.wake.notify_one();
}

void Recorder::stop() {
    Impl& m = *impl_;
    {
        std::lock_guard<std::mutex> lock(m.mutex);
        m.stopping = true;
    }
    m.wake.notify_one();
    if (m.writer.joinable()) m.writer.join();
}

std::string record_directory_problem(const std::filesystem::path& directory) {
    std::error_code error;
    fs::path existing = fs::absolute(directory, error);
    while (!existing.empty() && !fs::exists(existing, error) && existing != existing.root_path()) {
        existing = existing.parent_path();
    }
    if (!fs::is_directory(existing, error)) {
        return directory.string() + ": cannot be made, " + existing.string() +
               " is not a directory";
    }
    if (::access(existing.c_str(), W_OK | X_OK) != 0) {
        return directory.string() + ": cannot be made in " + existing.string() + ": " +
               std::strerror(errno);
    }
    return "";
}

void Recorder::note_metadata(const std::string& sensor, const std::string& json) {
    std::lock_guard<std::mutex> lock(metadata_mutex_);
    const fs::path first = folder_ / "metadata" / (sensor + ".json");
    try {
        if (!fs::exists(first)) {
            io::write_file_atomically(first, json);
            return;
        }
        if (io::read_file_bytes(first) == json) return;
        const fs::path later =
            folder_ / "metadata" / (sensor + "." + utc_stamp(realtime_ns()) + ".json");
        io::write_file_atomically(later, json);
        impl_->log->info("output.record: {}'s metadata changed; {} applies from now on", sensor,
                         later.string());
    } catch (const std::exception& error) {
        impl_->log->error("output.record: cannot write {}'s metadata into {}: {}", sensor,
                          folder_.string(), error.what());
    }
}

RecorderStats Recorder::stats() const {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    return impl_->stats;
}

std::string RecorderStats::problem() const {
    if (!enabled) return "";
    if (!recording) return "recording stopped: " + stopped_because;
    std::string text;
    if (files_removed > 0)
        text = std::to_string(files_removed) + " recording files removed for free disk space";
    if (queue_drops > 0) {
        text += (text.empty() ? "" : "; ") + std::to_string(queue_drops) +
                " datagrams not recorded (the disk did not keep up)";
    }
    return text;
}

// Writes everything queued in one pass (no lock while writing), wakes when the ring is an
// eighth full, every kDrainPeriod, or to stop: a wake-up per datagram would cost more than
// writing it.
void Recorder::Impl::run() {
    auto next_check = std::chrono::steady_clock::now();
    for (;;) {
        std::size_t pos = 0, available = 0;
        {
            std::unique_lock<std::mutex> lock(mutex);
            wake.wait_for(lock, kDrainPeriod,
                          [this] { return used >= ring.size() / 8 || stopping; });
            if (used == 0 && stopping) break;
            pos = tail;
            available = used;
        }
        std::size_t consumed = 0;
        std::uint64_t datagrams = 0, bytes = 0;
        while (consumed < available) {
            RecordHeader h{};
            if (pos + sizeof h <= ring.size()) std::memcpy(&h, ring.data() + pos, sizeof h);
            if (pos + sizeof h > ring.size() ||
                h.size == kWrap) {  // the rest of the ring is unused
                consumed += ring.size() - pos;
                pos = 0;
                continue;
            }
            if (!failed && write_record(h, ring.data() + pos + sizeof h)) {
                ++datagrams;
                bytes += h.size;
            }
            pos += record_bytes(h.size);
            consumed += record_bytes(h.size);
        }
        // Nothing consumed: tail is left alone. A producer that found the ring empty since the
        // snapshot has moved head and tail back to 0 and written there; the snapshot's tail
        // would point the next pass at stale bytes.
        if (consumed > 0) {
            std::lock_guard<std::mutex> lock(mutex);
            tail = pos;
            used -= consumed;
            stats.datagrams += datagrams;
            stats.bytes += bytes;
        }
        if (std::chrono::steady_clock::now() >= next_check) {
            next_check = std::chrono::steady_clock::now() + kCheckPeriod;
            if (!failed) check_free_space();
            if (dumper) pcap_dump_flush(dumper);
        }
    }
    close_file();
}

bool Recorder::Impl::write_record(const RecordHeader& h, const std::uint8_t* payload) {
    const double age_s = static_cast<double>(h.receive_time_ns - file_first_ns) * 1e-9;
    if (dumper && (static_cast<double>(file_bytes) >= config.max_file_mb * kBytesPerMb ||
                   age_s >= config.max_file_s)) {
        close_file();
        check_free_space();
        if (failed) return false;
    }
    if (!dumper) {
        open_file(h.receive_time_ns);
        if (failed) return false;
    }
    try {
        pcap::build_udp_frames({h.src_ip, h.src_port, dst_ip, h.dst_port}, ip_id++, payload, h.size,
                               0, &frames, /*udp_checksum=*/false);
    } catch (const std::exception& error) {  // larger than IPv4 allows: not from a socket
        stop_recording(error.what());
        return false;
    }
    const auto& frame = frames.front();
    pcap_pkthdr header{};
    header.ts.tv_sec = static_cast<time_t>(h.receive_time_ns / 1'000'000'000);
    header.ts.tv_usec = static_cast<suseconds_t>(h.receive_time_ns % 1'000'000'000);  // ns file
    header.caplen = static_cast<bpf_u_int32>(frame.size());
    header.len = header.caplen;
    pcap_dump(reinterpret_cast<u_char*>(dumper), &header, frame.data());
    if (std::ferror(pcap_dump_file(dumper))) {
        const std::string why = std::strerror(errno);
        {
            std::lock_guard<std::mutex> lock(mutex);
            ++stats.write_errors;
        }
        stop_recording("cannot write " + file.string() + ": " + why);
        return false;
    }
    file_bytes += sizeof header + frame.size();
    return true;
}

void Recorder::Impl::open_file(std::int64_t first_ns) {
    char sequence[16];
    std::snprintf(sequence, sizeof sequence, "%05zu", next_sequence++);
    file = folder / (std::string(sequence) + "-" + utc_stamp(first_ns) + ".pcap");
    pcap =
        pcap_open_dead_with_tstamp_precision(DLT_EN10MB, kSnapLength, PCAP_TSTAMP_PRECISION_NANO);
    std::FILE* stream = pcap ? std::fopen(file.c_str(), "wb") : nullptr;
    if (stream) std::setvbuf(stream, nullptr, _IOFBF, kFileBufferBytes);
    dumper = stream ? pcap_dump_fopen(pcap, stream) : nullptr;
    if (!dumper) {
        const std::string why = !pcap     ? "libpcap: out of memory"
                                : !stream ? std::strerror(errno)
                                          : pcap_geterr(pcap);
        if (stream) std::fclose(stream);
        if (pcap) pcap_close(pcap);
        pcap = nullptr;
        {
            std::lock_guard<std::mutex> lock(mutex);
            ++stats.write_errors;
        }
        stop_recording("cannot open " + file.string() + ": " + why);
        return;
    }
    files.push_back(file);
    file_bytes = 0;
    file_first_ns = first_ns;
    std::lock_guard<std::mutex> lock(mutex);
    ++stats.files;
    stats.file = file.string();
}

void Recorder::Impl::close_file() {
    if (!dumper) return;
    pcap_dump_flush(dumper);
    const bool error = std::ferror(pcap_dump_file(dumper)) != 0;
    pcap_dump_close(dumper);
    pcap_close(pcap);
    dumper = nullptr;
    pcap = nullptr;
    std::lock_guard<std::mutex> lock(mutex);
    stats.file.clear();
    if (error) ++stats.write_errors;
}

void Recorder::Impl::check_free_space() {
    const auto floor = static_cast<std::uint64_t>(config.min_free_mb * kBytesPerMb);
    while (free_space(folder) < floor) {
        // The open file is never removed: the oldest closed one goes first.
        const std::size_t closed = dumper ? files.size() - 1 : files.size();
        if (config.when_disk_low == LowDiskPolicy::kStop || closed == 0) {
            stop_recording("free disk space below output.record.min_free_mb (" +
                           std::to_string(static_cast<long long>(config.min_free_mb)) + " MB)" +
                           (config.when_disk_low == LowDiskPolicy::kStop
                                ? ""
                                : " with no older file left to remove"));
            return;
        }
        std::error_code error;
        fs::remove(files.front(), error);
        if (error) {
            stop_recording("cannot remove " + files.front().string() +
                           " for free space: " + error.message());
            return;
        }
        log->warn("recording: free disk space below {} MB: removed {}", config.min_free_mb,
                  files.front().string());
        files.erase(files.begin());
        std::lock_guard<std::mutex> lock(mutex);
        ++stats.files_removed;
    }
}

void Recorder::Impl::stop_recording(const std::string& why) {
    failed = true;
    close_file();
    log->error("recording stopped: {} (fusion goes on)", why);
    std::lock_guard<std::mutex> lock(mutex);
    stats.recording = false;
    stats.stopped_because = why;
}

}  // namespace lidarfuse::daemon
