#pragma once
// Clouds from DDS: a reader of sensor_msgs/PointCloud2 on one topic and domain (another
// station's fused cloud, or any ROS 2 LiDAR driver's), on a thread of its own that hands
// each readable cloud to a callback as points (daemon/point_cloud2_input.hpp) and counts
// what it could not read. Each sensor with `source: {dds: ...}` has one, in its DdsInput
// (daemon/dds_input.hpp).
//
// QoS as a ROS 2 subscriber of sensor data that must not miss a cloud while it keeps up:
// reliable, volatile, keep-last `depth`; a publisher that floods it replaces the oldest
// clouds in the reader's history before they are taken (never a stalled pipeline).

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "daemon/point_cloud2_input.hpp"

namespace lidarfuse::daemon {

struct PointCloud2SourceConfig {
    std::string name;   // for the log and the errors
    std::string topic;  // the DDS topic name, e.g. rt/station1/points
    int domain_id = 0;  // 0..232
    int depth = 4;      // keep-last history of the reader
};

// One cloud as the callback gets it; `points` is reused for the next cloud afterwards.
struct ReceivedCloud {
    std::int64_t stamp_ns = 0;     // header.stamp
    std::int64_t received_ns = 0;  // CLOCK_REALTIME when taken from the reader
    std::string frame_id;          // header.frame_id
    const PointCloud2Points* points = nullptr;
};

struct PointCloud2SourceCounters {
    std::uint64_t clouds = 0;             // read and handed on
    std::uint64_t refused = 0;            // layout not readable (last_error says why)
    std::uint64_t non_finite_points = 0;  // skipped in the clouds handed on
    std::string last_error;               // the newest refusal, naming topic and field
};

class PointCloud2Source {
public:
    using OnCloud = std::function<void(const ReceivedCloud&)>;
    // Creates the participant, topic and reader; throws std::runtime_error naming the
    // source, topic and domain when Cyclone refuses. Nothing is read before start().
    PointCloud2Source(PointCloud2SourceConfig config, OnCloud on_cloud);
    ~PointCloud2Source();
    PointCloud2Source(const PointCloud2Source&) = delete;
    PointCloud2Source& operator=(const PointCloud2Source&) = delete;

    void start();
    // Wakes the thread and joins it; the callback is not called afterwards.
    void stop();

    PointCloud2SourceCounters counters() const;
    // Writers matched on the topic now (a station's daemon that is up).
    int publishers() const;

private:
    void run();
    void take_available();
    void on_sample(const void* sample);

    PointCloud2SourceConfig config_;
    OnCloud on_cloud_;
    // Cyclone entities (dds_entity_t).
    std::int32_t participant_ = 0;
    std::int32_t reader_ = 0;
    std::int32_t stop_condition_ = 0;
    std::int32_t waitset_ = 0;
    std::thread thread_;
    std::atomic<bool> running_{false};
    PointCloud2Points points_;
    mutable std::mutex counters_mutex_;
    PointCloud2SourceCounters counters_;
};

}  // namespace lidarfuse::daemon
