// to_nested_json: the nested metadata form, as the simulator writes `<sensor>.json`.

#include <nlohmann/json.hpp>

#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::ouster {
namespace {

nlohmann::json matrix_json(const Eigen::Matrix4d& m) {
    nlohmann::json a = nlohmann::json::array();
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) a.push_back(m(r, c));
    return a;
}

}  // namespace

std::string to_nested_json(const SensorInfo& info) {
    using nlohmann::json;
    json doc;
    doc["sensor_info"] = {
        {"prod_sn", info.prod_sn},           {"prod_line", info.prod_line},
        {"prod_pn", info.prod_pn},           {"build_rev", info.build_rev},
        {"image_rev", info.image_rev},       {"status", info.status},
        {"initialization_id", info.init_id},
    };
    doc["beam_intrinsics"] = {
        {"beam_altitude_angles", info.beam_altitude_angles_deg},
        {"beam_azimuth_angles", info.beam_azimuth_angles_deg},
        {"lidar_origin_to_beam_origin_mm", info.lidar_origin_to_beam_origin_mm},
        {"beam_to_lidar_transform", matrix_json(info.beam_to_lidar_transform)},
    };
    doc["lidar_intrinsics"] = {
        {"lidar_to_sensor_transform", matrix_json(info.lidar_to_sensor_transform)}};
    doc["imu_intrinsics"] = {
        {"imu_to_sensor_transform", matrix_json(info.imu_to_sensor_transform)}};
    doc["lidar_data_format"] = {
        {"pixels_per_column", info.pixels_per_column},
        {"columns_per_packet", info.columns_per_packet},
        {"columns_per_frame", info.columns_per_frame},
        {"fps", info.frames_per_second},
        {"pixel_shift_by_row", info.pixel_shift_by_row},
        {"column_window", {info.column_window[0], info.column_window[1]}},
        {"udp_profile_lidar", to_string(info.udp_profile_lidar)},
        {"udp_profile_imu", to_string(info.udp_profile_imu)},
    };
    json config = {
        {"columns_per_packet", info.columns_per_packet},
        {"udp_port_lidar", info.udp_port_lidar},
        {"udp_port_imu", info.udp_port_imu},
        {"udp_profile_lidar", to_string(info.udp_profile_lidar)},
        {"udp_profile_imu", to_string(info.udp_profile_imu)},
        {"azimuth_window", {info.azimuth_window_mdeg[0], info.azimuth_window_mdeg[1]}},
    };
    if (!info.lidar_mode.empty()) config["lidar_mode"] = info.lidar_mode;
    if (!info.udp_dest.empty()) config["udp_dest"] = info.udp_dest;
    if (!info.timestamp_mode.empty()) config["timestamp_mode"] = info.timestamp_mode;
    doc["config_params"] = std::move(config);
    doc["calibration_status"] = json::object();
    return doc.dump(2) + "\n";
}

}  // namespace lidarfuse::ouster
