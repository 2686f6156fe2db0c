#pragma once
// A sensor whose scans are sensor_msgs/PointCloud2 clouds on DDS (station.yaml
// `source: {dds: ...}`): another station's fused cloud, or a ROS 2 LiDAR driver's. Its
// PointCloud2Source (daemon/point_cloud2_source.hpp) hands each cloud over on its own thread;
// here it becomes a ScanMessage in a queue that the sync thread reads as it reads a
// receiver's, so the synchroniser, the FusionEngine, the outputs and the health treat it as
// they treat an Ouster sensor.
//
// What differs from an Ouster scan: the scan time is the header stamp (plus the sensor's
// time_offset_ns), there are no per-point times (no deskew for this input) and no
// intensities (zeros in the fused cloud). Change detection bins the points spherically, as
// for any scan. The first cloud's frame_id is the input's frame: a cloud in another frame is
// refused and counted, since its points would be registered as if they were in this one.
// Refused as well: clouds without points, and clouds stamped 0 (no time at all).

#include <spdlog/logger.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "daemon/dds_input_status.hpp"
#include "daemon/drop_oldest_queue.hpp"
#include "daemon/point_cloud2_source.hpp"
#include "daemon/sensor_ingest.hpp"
#include "drivers/station/station_config.hpp"

namespace lidarfuse::daemon {

class DdsInput {
public:
    // Creates the reader (throws std::runtime_error naming the sensor and topic when
    // Cyclone refuses); nothing is read before start(). `sensor` outlives this object.
    DdsInput(SensorIngest* sensor, const station::DdsSource& source,
             std::shared_ptr<spdlog::logger> log);
    void start() { source_.start(); }
    void stop() { source_.stop(); }

    // The scans for the sync thread; a full queue drops its oldest (counted).
    DropOldestQueue<ScanMessage>& queue() { return queue_; }
    const DropOldestQueue<ScanMessage>& queue() const { return queue_; }
    DdsInputStatus status() const;
    std::size_t sensor_index() const { return sensor_->index; }

private:
    void on_cloud(const ReceivedCloud& cloud);
    void refuse(const std::string& why);
    void note_rate(std::int64_t t_ns);

    SensorIngest* sensor_;
    station::DdsSource config_;
    std::shared_ptr<spdlog::logger> log_;
    DropOldestQueue<ScanMessage> queue_{8};
    // Reader thread only (status() reads frame_id_ and the refusals under mutex_).
    static constexpr std::size_t kPeriods = 16;
    std::int64_t last_t_ns_ = 0;
    std::array<std::int64_t, kPeriods> periods_{};  // ns; 0 = not yet seen
    std::size_t next_period_ = 0;
    mutable std::mutex mutex_;
    std::string frame_id_;
    std::uint64_t refused_ = 0;
    std::string last_error_;
    PointCloud2Source source_;  // last: its thread stops before the members above go
};

}  // namespace lidarfuse::daemon
