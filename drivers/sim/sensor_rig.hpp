#pragma once
// One virtual sensor: its identity on the network, its Ouster metadata, and its pose in the
// world over time (nominal mount on the pole plus the pole head's sway).
//
// Frames: T_world_sensor maps points from the Ouster *sensor* frame (x forward, z up,
// origin on the base plate as Ouster defines it) into the world. The nominal orientation
// is Rz(yaw) * Ry(tilt): x pitched down by `tilt`; the pole tilt rotates all of it about
// the pole base, the sensor frame origin sitting at the pole head.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>

#include "drivers/ouster/metadata.hpp"
#include "drivers/sim/pendulum.hpp"
#include "drivers/sim/scene.hpp"

namespace lidarfuse::sim {

struct SensorRigParams {
    int index = 0;  // in the whole simulation: serial number, phase, sway, render streams
    // Of several stations (SimParams::stations): the station and the sensor's number in it,
    // which gives its name, address and port, as in a simulation of that station alone.
    int station = 0;
    int index_in_station = -1;  // -1: index (one station)
    int columns_per_frame = 1024;
    int frames_per_second = 20;
    ouster::UdpProfileLidar profile = ouster::UdpProfileLidar::kLegacy;
    std::uint64_t seed = 1;
    bool motion = true;
    double duration_s = 10.0;               // pendulum integrated over [0, duration + 1 s]
    std::uint16_t first_lidar_port = 7502;  // sensor k: first_lidar_port + 2k
};

// Network identity: sensor k sends from 169.254.10.(11+k) to 169.254.10.1, lidar port
// first_lidar_port + 2k, by default 7502 + 2k (IMU port one above).
constexpr std::uint32_t kHostIp = 0xA9FE0A01u;  // 169.254.10.1
inline std::uint32_t sensor_ip(int index) {
    return 0xA9FE0A0Bu + static_cast<std::uint32_t>(index);
}
inline std::uint16_t sensor_lidar_port(int index, std::uint16_t first = 7502) {
    return static_cast<std::uint16_t>(first + 2 * index);
}
inline std::string sensor_name(int index) { return "lidar" + std::to_string(index); }

// The number that names the sensor and sets its address and port.
inline int network_index(const SensorRigParams& p) {
    return p.index_in_station >= 0 ? p.index_in_station : p.index;
}

class SensorRig {
public:
    SensorRig(const SensorMount& mount, const SensorRigParams& params);

    const std::string& name() const { return name_; }
    int index() const { return params_.index; }
    int station() const { return params_.station; }
    const ouster::SensorInfo& info() const { return info_; }
    std::uint32_t src_ip() const { return sensor_ip(network_index(params_)); }
    std::uint16_t lidar_port() const { return info_.udp_port_lidar; }
    const SensorMount& mount() const { return mount_; }
    // Start of this sensor's frame 0 after the common time origin (ns): sensors are not
    // phase locked; their phases differ by less than a quarter frame so that frame k of
    // every sensor belongs together.
    std::int64_t phase_ns() const { return phase_ns_; }
    std::uint16_t first_frame_id() const { return first_frame_id_; }

    // Pose at time t_s since the time origin. Without motion: the nominal pose.
    Eigen::Isometry3d T_world_sensor(double t_s) const;
    Eigen::Isometry3d nominal_T_world_sensor() const;

private:
    SensorMount mount_;
    SensorRigParams params_;
    std::string name_;
    ouster::SensorInfo info_;
    std::optional<PendulumTrajectory> pendulum_;
    std::int64_t phase_ns_ = 0;
    std::uint16_t first_frame_id_ = 0;
};

// Nested-form metadata of a simulated OS1-64 (real intrinsics, this rig's identity).
ouster::SensorInfo make_sensor_info(const SensorRigParams& params);

}  // namespace lidarfuse::sim
