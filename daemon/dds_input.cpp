#include "daemon/dds_input.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/common/point_cloud.hpp"
#include "daemon/log_throttle.hpp"

namespace lidarfuse::daemon {

namespace {

PointCloud2SourceConfig source_config(const SensorIngest& sensor,
                                      const station::DdsSource& source) {
    PointCloud2SourceConfig c;
    c.name = "sensor \"" + sensor.name + "\"";
    c.topic = source.topic;
    c.domain_id = source.domain_id;
    // 400 ms of clouds at 20 Hz: the reader thread only copies a cloud into the scan queue,
    // so it falls behind only when the machine does not run it (seen under a parallel ctest
    // with 4, 200 ms); a few MB more per source.
    c.depth = 8;
    return c;
}

}  // namespace

DdsInput::DdsInput(SensorIngest* sensor, const station::DdsSource& source,
                   std::shared_ptr<spdlog::logger> log)
    : sensor_(sensor),
      config_(source),
      log_(std::move(log)),
      source_(source_config(*sensor, source),
              [this](const ReceivedCloud& cloud) { on_cloud(cloud); }) {
    // Nothing to wait for: the clouds carry their points, in their own frame.
    sensor_->metadata_known.store(true);
    if (source.frame_id) frame_id_ = *source.frame_id;
    sensor_->metadata_status.source = "dds " + source.topic;
}

void DdsInput::refuse(const std::string& why) {
    std::uint64_t refused = 0;
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        refused = ++refused_;
        last_error_ = "sensor \"" + sensor_->name + "\" (" + config_.topic + "): " + why;
    }
    sensor_->scans_rejected.fetch_add(1);
    if (logged_occurrence(refused)) {
        log_->warn("sensor \"{}\": cloud refused ({} so far): {}", sensor_->name, refused, why);
    }
}

// The input's frame rate from its stamps, for the synchroniser's default window when it is
// the root (frames_per_second, as an Ouster sensor's metadata gives it). A publisher that
// drops frames (a station whose fusion falls behind) leaves gaps of several periods, so the
// rate comes from the shortest of the last kPeriods periods, not their mean; gaps above 1 s
// (a restart) do not count.
void DdsInput::note_rate(std::int64_t t_ns) {
    const std::int64_t period = t_ns - last_t_ns_;
    last_t_ns_ = t_ns;
    if (period <= 0 || period > 1'000'000'000) return;
    periods_[next_period_++ % kPeriods] = period;
    std::int64_t shortest = period;
    for (const std::int64_t p : periods_) {
        if (p > 0) shortest = std::min(shortest, p);
    }
    const int rate = static_cast<int>(std::lround(1e9 / static_cast<double>(shortest)));
    sensor_->frames_per_second.store(std::max(1, std::min(rate, 100)));
}

void DdsInput::on_cloud(const ReceivedCloud& cloud) {
    if (cloud.stamp_ns == 0) return refuse("header.stamp is 0: the cloud has no time");
    if (cloud.points->points.empty()) return refuse("no finite points");
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        if (frame_id_.empty()) frame_id_ = cloud.frame_id;
    }
    if (cloud.frame_id != frame_id_) {
        const char* whose = config_.frame_id ? "source.dds.frame_id" : "the first cloud's";
        return refuse("frame_id \"" + cloud.frame_id + "\", expected \"" + frame_id_ + "\" (" +
                      whose + ")");
    }
    ScanMessage m = sensor_->take_spare_scan();
    m.sensor = sensor_->index;
    m.t_ns = cloud.stamp_ns + sensor_->time_offset_ns;
    m.complete_steady_ns = steady_ns();
    m.complete_realtime_ns = cloud.received_ns;
    core::cast_points(cloud.points->points, &m.points);
    note_rate(m.t_ns);
    sensor_->scans.fetch_add(1);
    sensor_->last_completeness.store(1.0);
    sensor_->clock_offset_ns.store(m.t_ns - cloud.received_ns);
    sensor_->last_scan_steady_ns.store(m.complete_steady_ns);
    queue_.push(std::move(m));
}

DdsInputStatus DdsInput::status() const {
    const PointCloud2SourceCounters c = source_.counters();
    DdsInputStatus s;
    s.topic = config_.topic;
    s.domain_id = config_.domain_id;
    s.publishers = source_.publishers();
    s.clouds = c.clouds;
    s.non_finite_points = c.non_finite_points;
    const std::lock_guard<std::mutex> lock(mutex_);
    s.refused = c.refused + refused_;
    s.frame_id = frame_id_;
    s.last_error = last_error_.empty() ? c.last_error : last_error_;
    return s;
}

}  // namespace lidarfuse::daemon
