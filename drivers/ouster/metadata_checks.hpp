#pragma once
// Internal to drivers/ouster: the semantic checks shared by parse_metadata() (reporting
// JSON paths of the document's form) and validate_sensor_info() (reporting member names).

#include <set>
#include <string>
#include <vector>

#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::ouster::detail {

// Names under which problems are reported. The prefixes are used by the parser to locate
// keys ("sensor_info." for nested documents, "" for legacy flat ones).
struct MetadataPaths {
    std::string sensor;
    std::string beam;
    std::string format;
    std::string config;
    std::string lidar_to_sensor;
    std::string imu_to_sensor;
    // Members that have no JSON key of the same name (SensorInfo built in code).
    bool members = false;

    std::string altitude() const { return beam + "beam_altitude_angles" + (members ? "_deg" : ""); }
    std::string azimuth() const { return beam + "beam_azimuth_angles" + (members ? "_deg" : ""); }
    std::string beam_to_lidar() const { return beam + "beam_to_lidar_transform"; }
    std::string beam_origin() const { return beam + "lidar_origin_to_beam_origin_mm"; }
    std::string pixels_per_column() const { return format + "pixels_per_column"; }
    std::string columns_per_frame() const { return format + "columns_per_frame"; }
    std::string columns_per_packet() const { return format + "columns_per_packet"; }
    std::string pixel_shift() const { return format + "pixel_shift_by_row"; }
    std::string column_window() const { return format + "column_window"; }
    std::string azimuth_window() const {
        return config + (members ? "azimuth_window_mdeg" : "azimuth_window");
    }
};

// Paths naming SensorInfo members (for validate_sensor_info).
MetadataPaths member_paths();

// Appends a problem for every inconsistency in `info`; keys listed in `bad` already had a
// type problem reported and are skipped.
void check_semantics(const SensorInfo& info, const MetadataPaths& paths,
                     const std::set<std::string>& bad, std::vector<std::string>* problems);

}  // namespace lidarfuse::ouster::detail
