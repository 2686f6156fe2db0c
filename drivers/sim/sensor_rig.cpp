#include "drivers/sim/sensor_rig.hpp"

#include <stdexcept>

#include "drivers/sim/os1_intrinsics.hpp"
#include "drivers/sim/rng.hpp"

namespace lidarfuse::sim {

ouster::SensorInfo make_sensor_info(const SensorRigParams& p) {
    ouster::SensorInfo info;
    CounterRng rng(p.seed, 0x6964656E74ULL /* "ident" */, static_cast<std::uint64_t>(p.index));
    info.prod_sn = std::to_string(992300001000ULL + static_cast<std::uint64_t>(p.index));
    info.prod_line = os1_64::kProdLine;
    info.prod_pn = os1_64::kProdPn;
    info.build_rev = os1_64::kBuildRev;
    info.image_rev = os1_64::kImageRev;
    info.status = "RUNNING";
    // Distinct 24-bit init ids (the high byte carries the index).
    info.init_id = ((static_cast<std::uint32_t>(p.index) + 1) << 16) |
                   static_cast<std::uint32_t>(rng.next() & 0xFFFFu);
    info.columns_per_frame = p.columns_per_frame;
    info.frames_per_second = p.frames_per_second;
    info.lidar_mode =
        std::to_string(p.columns_per_frame) + "x" + std::to_string(p.frames_per_second);
    info.pixels_per_column = os1_64::kBeams;
    info.columns_per_packet = 16;
    info.udp_profile_lidar = p.profile;
    info.beam_altitude_angles_deg.assign(os1_64::kBeamAltitudeDeg.begin(),
                                         os1_64::kBeamAltitudeDeg.end());
    info.beam_azimuth_angles_deg.assign(os1_64::kBeamAzimuthDeg.begin(),
                                        os1_64::kBeamAzimuthDeg.end());
    info.pixel_shift_by_row =
        ouster::pixel_shift_from_azimuths(info.beam_azimuth_angles_deg, p.columns_per_frame);
    info.column_window = {0, p.columns_per_frame - 1};
    info.lidar_origin_to_beam_origin_mm = os1_64::kLidarOriginToBeamOriginMm;
    info.beam_to_lidar_transform = Eigen::Matrix4d::Identity();
    info.beam_to_lidar_transform(0, 3) = os1_64::kLidarOriginToBeamOriginMm;
    info.lidar_to_sensor_transform = Eigen::Matrix4d::Identity();
    info.lidar_to_sensor_transform(0, 0) = -1;
    info.lidar_to_sensor_transform(1, 1) = -1;
    info.lidar_to_sensor_transform(2, 3) = os1_64::kLidarToSensorZMm;
    info.imu_to_sensor_transform = Eigen::Matrix4d::Identity();
    for (int k = 0; k < 3; ++k) info.imu_to_sensor_transform(k, 3) = os1_64::kImuToSensorMm[k];
    info.udp_port_lidar = sensor_lidar_port(network_index(p), p.first_lidar_port);
    info.udp_port_imu = static_cast<std::uint16_t>(info.udp_port_lidar + 1);
    info.udp_dest = "169.254.10.1";
    info.timestamp_mode = "TIME_FROM_PTP_1588";
    info.azimuth_window_mdeg = {0, 360000};
    info.form = ouster::MetadataForm::kBuiltInCode;
    return info;
}

SensorRig::SensorRig(const SensorMount& mount, const SensorRigParams& params)
    : mount_(mount),
      params_(params),
      name_(sensor_name(network_index(params))),
      info_(make_sensor_info(params)) {
    const auto problems = ouster::validate_sensor_info(info_);
    if (!problems.empty()) {
        std::string all;
        for (const auto& p : problems) all += "\n  " + p;
        throw std::logic_error("sim: metadata of " + name_ + " is invalid:" + all);
    }
    CounterRng rng(params.seed, 0x7068617365ULL /* "phase" */,
                   static_cast<std::uint64_t>(params.index));
    const double frame_ns = 1e9 / params.frames_per_second;
    phase_ns_ = static_cast<std::int64_t>(rng.uniform(0.0, 0.25) * frame_ns);
    first_frame_id_ = static_cast<std::uint16_t>(rng.next() & 0xFFFFu);
    if (params.motion) {
        PendulumParams pp;
        pp.length_m = mount.pole_height_m;
        pendulum_.emplace(draw_pendulum_init(params.seed, params.index), params.duration_s + 1.0,
                          pp);
    }
}

Eigen::Isometry3d SensorRig::nominal_T_world_sensor() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(mount_.yaw_rad, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(mount_.tilt_rad, Eigen::Vector3d::UnitY()))
                     .toRotationMatrix();
    T.translation() = mount_.pole_base + Eigen::Vector3d(0, 0, mount_.pole_height_m);
    return T;
}

Eigen::Isometry3d SensorRig::T_world_sensor(double t_s) const {
    const Eigen::Isometry3d nominal = nominal_T_world_sensor();
    if (!pendulum_) return nominal;
    // Rotate the whole mount about the pole base by the pole's tilt.
    const Eigen::Quaterniond tilt = pendulum_->tilt(t_s);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = tilt.toRotationMatrix() * nominal.linear();
    T.translation() = mount_.pole_base + tilt * Eigen::Vector3d(0, 0, mount_.pole_height_m);
    return T;
}

}  // namespace lidarfuse::sim
