#pragma once
// The simulator: a scene, n virtual OS1-64 on swaying poles, road users, and the packet
// stream they produce, in capture order.
//
// Time: t = 0 is the common origin; wire and capture timestamps are kEpochNs + t (PTP
// time, ns). Sensor k's frame f starts at phase_k + f / fps and its column m fires at
// start + m / (W fps) (integer ns), cast from the pose of that instant. A packet is
// captured 30-70 us after its last column (network latency, seeded jitter).
//
// Threads: run() renders the packets of one frame slot (frame f of every sensor) on
// `threads` workers; every random draw is keyed by (seed, sensor, frame, column, row), so
// the output is byte-identical for any thread count.

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "drivers/io/pose_csv.hpp"
#include "drivers/ouster/metadata.hpp"
#include "drivers/sim/faults.hpp"
#include "drivers/sim/scene.hpp"
#include "drivers/sim/sensor_model.hpp"
#include "drivers/sim/sensor_rig.hpp"
#include "drivers/sim/traffic.hpp"

namespace lidarfuse::sim {

constexpr std::int64_t kEpochNs = 1'763'700'000'000'000'000LL;  // 2025-11-21, PTP time

struct SimParams {
    Scenario scenario = Scenario::kStraight;
    int sensors = 4;  // in all stations together
    // Several stations along one road (SceneParams): sensors / stations each, station by
    // station; a sensor's name, address and port are those of its number in its station.
    int stations = 1;
    double station_spacing_m = 80.0;
    double seconds = 10.0;
    int columns_per_frame = 1024;
    int frames_per_second = 20;
    ouster::UdpProfileLidar profile = ouster::UdpProfileLidar::kLegacy;
    std::uint64_t seed = 1;
    bool motion = true;
    bool traffic = true;
    SensorModelParams sensor;  // noise sigma, ranges, dropouts
    FaultPlan faults;
    int threads = 0;                        // 0: std::thread::hardware_concurrency()
    std::uint16_t first_lidar_port = 7502;  // sensor k sends to first_lidar_port + 2k
};

// One UDP datagram of the capture.
struct SimDatagram {
    std::int64_t capture_ns = 0;  // host capture time, ns since the Unix epoch
    int sensor = 0;
    std::uint32_t src_ip = 0, dst_ip = 0;  // host byte order
    std::uint16_t src_port = 0, dst_port = 0;
    std::vector<std::uint8_t> payload;
};

class DatagramSink {
public:
    virtual ~DatagramSink() = default;
    // Called in capture-time order from the thread that called Simulator::run().
    virtual void write(const SimDatagram& datagram) = 0;
};

struct SimStats {
    std::uint64_t rays = 0;
    std::uint64_t returns = 0;
    std::uint64_t packets_rendered = 0;
    std::uint64_t datagrams_sent = 0;  // after faults
    double render_wall_s = 0;          // time spent rendering (excludes the sink)
};

class Simulator {
public:
    // Throws std::invalid_argument on bad parameters (listing each).
    explicit Simulator(const SimParams& params);
    ~Simulator();

    const SimParams& params() const { return params_; }
    const Scene& scene() const { return scene_; }
    const std::vector<SensorRig>& rigs() const { return rigs_; }
    const Traffic* traffic() const { return traffic_.get(); }
    int frames() const { return frames_; }

    // Absolute time (ns) of column m of frame f of sensor k (true time, no clock fault).
    std::int64_t column_time_ns(int sensor, int frame, int measurement_id) const;
    // T_world_sensor of sensor k at frame f's timestamp (its column 0), one row per sensor
    // per frame, frames in order.
    std::vector<io::PoseRecord> ground_truth() const;

    // Renders every frame and passes the datagrams to `sink` in capture order.
    SimStats run(DatagramSink& sink);
    // Optional: called by run() on its thread after each frame slot went to the sink, with
    // the slots done and their total (progress).
    void set_on_frame(std::function<void(int done, int total)> on_frame) {
        on_frame_ = std::move(on_frame);
    }

private:
    struct Impl;
    SimParams params_;
    Scene scene_;
    std::vector<SensorRig> rigs_;
    std::unique_ptr<Traffic> traffic_;
    int frames_ = 0;
    std::function<void(int, int)> on_frame_;
    std::unique_ptr<Impl> impl_;
};

}  // namespace lidarfuse::sim
