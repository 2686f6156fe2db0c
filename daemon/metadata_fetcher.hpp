#pragma once
// The metadata of a sensor named by hostname (station.yaml sensors[].hostname), from the
// sensor's HTTP API (drivers/ouster/sensor_http.hpp), on a thread of its own per sensor
// (`lf-meta-<sensor>`), so a sensor that does not answer never holds up the others.
//
// - At start it fetches the metadata (first configuring the sensor when
//   sensors[].configure asks for it and the sensor runs otherwise), keeps a copy in
//   <output.directory>/<sensor>.json (written atomically) and in the recording, and
//   hands it to the sensor's receiver, which installs it at its next datagram.
// - It fetches again when the data says the sensor changed under the daemon: scans with
//   another init_id than the metadata's (a reboot or re-initialisation), or the mode
//   check flagging the sensor (MODE_MISMATCH: another lidar_mode or profile). A fetch that
//   does not explain the data (same init_id, same layout) counts as a failure.
// - Failures (unreachable, time-outs, bad answers, a sensor still INITIALIZING) are logged
//   (a warning on the first and whenever the reason changes, then at debug), counted
//   in the sensor's MetadataStatus, and retried with a back-off of 0.5 s doubling to 30 s.

#include <spdlog/logger.h>

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "daemon/recorder.hpp"
#include "daemon/sensor_ingest.hpp"
#include "drivers/ouster/sensor_http.hpp"
#include "drivers/station/station_config.hpp"

namespace lidarfuse::daemon {

struct MetadataFetcherParams {
    ouster::SensorHttpParams http;  // host and port from the station config
    double apply_timeout_s = 30.0;  // a re-initialising sensor's time to RUNNING
    double first_retry_s = 0.5, max_retry_s = 30.0;
    double poll_s = 0.1;  // how often the sensor's atomics are looked at
};

class MetadataFetcher {
public:
    MetadataFetcher(SensorIngest* sensor, const station::SensorConfig& config,
                    const MetadataFetcherParams& params, std::filesystem::path output_directory,
                    Recorder* recorder, std::shared_ptr<spdlog::logger> log);
    ~MetadataFetcher();  // stops
    MetadataFetcher(const MetadataFetcher&) = delete;
    MetadataFetcher& operator=(const MetadataFetcher&) = delete;

    void start();
    // Returns once the thread has ended: at once between requests, else after the request
    // under way has timed out or been answered.
    void stop();

private:
    enum class Need { kNothing, kFirst, kInitId, kMode };
    Need need() const;
    void run();
    // One attempt; returns the error text ("" on success).
    std::string attempt(Need need);
    std::string check_explains(Need need, const ouster::SensorInfo& fetched) const;
    void maybe_configure(ouster::FetchedMetadata* fetched);
    void hand_over(const ouster::FetchedMetadata& fetched);
    void note_failure(const std::string& error);
    void clear_error();
    void sleep_for(double seconds);

    SensorIngest* sensor_;
    station::SensorConfig config_;
    MetadataFetcherParams params_;
    std::filesystem::path output_directory_;
    Recorder* recorder_;
    std::shared_ptr<spdlog::logger> log_;
    std::string source_;  // http://host:port, for messages

    bool have_current_ = false;   // fetcher thread
    ouster::SensorInfo current_;  // the last version handed over
    std::string last_logged_error_;
    double retry_s_ = 0.0;

    std::mutex mutex_;
    std::condition_variable wake_;
    bool stopping_ = false;
    std::atomic<bool> cancel_{false};
    std::thread thread_;
};

// This host's IPv4 address on the way to `host` (the source address the kernel picks to
// reach it): what a sensor's udp_dest must be to send here. Throws std::runtime_error.
std::string local_address_towards(const std::string& host);

}  // namespace lidarfuse::daemon
