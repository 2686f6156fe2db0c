#include "daemon/metadata_fetcher.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <pthread.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

#include "drivers/io/cloud_file_support.hpp"
#include "drivers/net/ipv4_address.hpp"

namespace lidarfuse::daemon {

namespace {

// The parts of the metadata that decide how packets are read: when a fetch after a mode
// mismatch brings none of them changed, it did not explain the mismatch.
bool same_layout(const ouster::SensorInfo& a, const ouster::SensorInfo& b) {
    return a.lidar_mode == b.lidar_mode && a.udp_profile_lidar == b.udp_profile_lidar &&
           a.columns_per_packet == b.columns_per_packet &&
           a.pixels_per_column == b.pixels_per_column && a.column_window == b.column_window;
}

std::string describe(const ouster::SensorInfo& info) {
    return info.lidar_mode + " " + ouster::to_string(info.udp_profile_lidar) + ", init_id " +
           std::to_string(info.init_id);
}

}  // namespace

std::string local_address_towards(const std::string& host) {
    sockaddr_in remote{};
    remote.sin_family = AF_INET;
    remote.sin_port = htons(7502);  // any port: connect() on UDP only picks the route
    remote.sin_addr.s_addr = htonl(net::resolve_ipv4(host));
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
    sockaddr_in local{};
    socklen_t length = sizeof(local);
    const bool ok =
        ::connect(fd, reinterpret_cast<const sockaddr*>(&remote), sizeof(remote)) == 0 &&
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &length) == 0;
    const int error = errno;
    ::close(fd);
    if (!ok) {
        throw std::runtime_error("no route to " + host +
                                 " (for udp_dest): " + std::strerror(error));
    }
    return net::ipv4_to_string(ntohl(local.sin_addr.s_addr));
}

MetadataFetcher::MetadataFetcher(SensorIngest* sensor, const station::SensorConfig& config,
                                 const MetadataFetcherParams& params,
                                 std::filesystem::path output_directory, Recorder* recorder,
                                 std::shared_ptr<spdlog::logger> log)
    : sensor_(sensor),
      config_(config),
      params_(params),
      output_directory_(std::move(output_directory)),
      recorder_(recorder),
      log_(std::move(log)),
      source_("http://" + params.http.host + ":" + std::to_string(params.http.port)) {
    std::lock_guard<std::mutex> lock(sensor_->counters_mutex);
    sensor_->metadata_status.source = source_;
}

MetadataFetcher::~MetadataFetcher() { stop(); }

void MetadataFetcher::start() {
    thread_ = std::thread([this] {
        const std::string name = ("lf-meta-" + config_.name).substr(0, 15);
        ::pthread_setname_np(::pthread_self(), name.c_str());
        run();
    });
}

void MetadataFetcher::stop() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stopping_ = true;
    }
    cancel_.store(true);
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
}

MetadataFetcher::Need MetadataFetcher::need() const {
    if (!have_current_) return Need::kFirst;
    if (sensor_->has_pending.load(std::memory_order_acquire)) return Need::kNothing;
    const std::uint32_t seen = sensor_->packet_init_id.load(std::memory_order_relaxed);
    if (seen != 0 && current_.init_id != 0 && seen != current_.init_id) return Need::kInitId;
    if (sensor_->mode_mismatch.load(std::memory_order_relaxed)) return Need::kMode;
    return Need::kNothing;
}

void MetadataFetcher::run() {
    retry_s_ = params_.first_retry_s;
    for (;;) {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            if (stopping_) return;
        }
        const Need need_now = need();
        if (need_now == Need::kNothing) {
            if (!last_logged_error_.empty()) clear_error();  // the data agrees again
            sleep_for(params_.poll_s);
            continue;
        }
        const std::string error = attempt(need_now);
        if (error.empty()) {
            retry_s_ = params_.first_retry_s;
            continue;
        }
        note_failure(error);
        sleep_for(retry_s_);
        retry_s_ = std::min(retry_s_ * 2.0, params_.max_retry_s);
    }
}

std::string MetadataFetcher::attempt(Need need_now) {
    try {
        ouster::FetchedMetadata fetched = ouster::fetch_metadata(params_.http);
        if (!fetched.status.empty() && fetched.status != "RUNNING") {
            return source_ + ": the sensor is " + fetched.status + ", not RUNNING yet";
        }
        if (config_.configure.enabled) maybe_configure(&fetched);
        const std::string unexplained = check_explains(need_now, fetched.info);
        {
            std::lock_guard<std::mutex> lock(sensor_->counters_mutex);
            ++sensor_->metadata_status.fetches;
            sensor_->metadata_status.endpoint = fetched.endpoint;
        }
        if (!unexplained.empty()) return unexplained;
        hand_over(fetched);
        return "";
    } catch (const std::exception& error) {
        return error.what();
    }
}

// Why a fetch made for `need_now` does not account for what the data shows ("" if it does).
std::string MetadataFetcher::check_explains(Need need_now,
                                            const ouster::SensorInfo& fetched) const {
    if (need_now == Need::kInitId) {
        const std::uint32_t seen = sensor_->packet_init_id.load(std::memory_order_relaxed);
        if (fetched.init_id != seen) {
            return source_ + ": metadata has init_id " + std::to_string(fetched.init_id) +
                   ", the packets carry " + std::to_string(seen);
        }
    } else if (need_now == Need::kMode && same_layout(fetched, current_)) {
        return source_ + ": metadata still says " + describe(fetched) +
               ", which the packets disagree with";
    }
    return "";
}

// sensors[].configure: set what differs, wait for the sensor to run again, fetch again.
void MetadataFetcher::maybe_configure(ouster::FetchedMetadata* fetched) {
    ouster::SensorConfigRequest request;
    request.udp_dest = config_.configure.udp_dest ? *config_.configure.udp_dest
                                                  : local_address_towards(params_.http.host);
    request.udp_port_lidar = config_.udp_port;
    request.lidar_mode = config_.configure.lidar_mode;
    request.timestamp_mode = config_.configure.timestamp_mode;
    request.operating_mode = "NORMAL";
    const auto differing = ouster::differing_config(request, fetched->info);
    if (differing.empty()) return;
    std::string keys;
    for (const auto& k : differing) keys += (keys.empty() ? "" : ", ") + k;
    log_->info("{}: configuring the sensor at {} ({}: {})", config_.name, source_, keys,
               ouster::to_json(request));
    ouster::configure_sensor(params_.http, request, params_.apply_timeout_s, &cancel_);
    {
        std::lock_guard<std::mutex> lock(sensor_->counters_mutex);
        ++sensor_->metadata_status.configured;
    }
    *fetched = ouster::fetch_metadata(params_.http);
}

void MetadataFetcher::hand_over(const ouster::FetchedMetadata& fetched) {
    const bool changed = have_current_;
    // A copy an operator can read and offline tools can use; the sensor is fused without it.
    try {
        std::filesystem::create_directories(output_directory_);
        io::write_file_atomically(output_directory_ / (config_.name + ".json"), fetched.json);
    } catch (const std::exception& error) {
        log_->warn("{}: cannot keep a copy of its metadata: {}", config_.name, error.what());
    }
    if (recorder_) recorder_->note_metadata(config_.name, fetched.json);
    {
        std::lock_guard<std::mutex> lock(sensor_->pending_mutex);
        sensor_->pending_info = fetched.info;
        sensor_->has_pending.store(true, std::memory_order_release);
    }
    if (changed) {
        std::lock_guard<std::mutex> lock(sensor_->counters_mutex);
        ++sensor_->metadata_status.changes;
    }
    clear_error();
    log_->info("{}: metadata from {}{} ({}, firmware {}, serial {}){}", config_.name, source_,
               fetched.endpoint, describe(fetched.info), fetched.info.build_rev,
               fetched.info.prod_sn, changed ? ", replacing " + describe(current_) : "");
    current_ = fetched.info;
    have_current_ = true;
}

void MetadataFetcher::clear_error() {
    std::lock_guard<std::mutex> lock(sensor_->counters_mutex);
    sensor_->metadata_status.last_error.clear();
    last_logged_error_.clear();
}

void MetadataFetcher::note_failure(const std::string& error) {
    {
        std::lock_guard<std::mutex> lock(sensor_->counters_mutex);
        ++sensor_->metadata_status.failures;
        sensor_->metadata_status.last_error = error;
    }
    // A sensor that stays away would otherwise log every retry.
    const auto level = error == last_logged_error_ ? spdlog::level::debug : spdlog::level::warn;
    log_->log(level, "{}: fetching its metadata failed: {}; retrying in {:.1f} s", config_.name,
              error, retry_s_);
    last_logged_error_ = error;
}

void MetadataFetcher::sleep_for(double seconds) {
    std::unique_lock<std::mutex> lock(mutex_);
    wake_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return stopping_; });
}

}  // namespace lidarfuse::daemon
