#pragma once
// station.yaml's `world:` section (config/station.schema.md, "World frame"): the frame the
// fused cloud and the poses are expressed in, as core::WorldFrameParams. Read by lidarfused
// (with the rest of its config) and `lidarfuse fuse`, so that a capture is fused offline in
// the frame the station publishes. Validated with every problem's key path, e.g.
// `world.positions: expected at least 3 sensors, got 2`.
//
//   world:
//     frame: road                 # road (default) | geo | sensor
//     frame_id: utm               # geo: the world frame's tf name (rt/tf_static parent)
//     positions:                  # geo: known positions of >= 3 sensors (m), or ...
//       north: [691234.512, 5335012.331, 512.20]
//     T_world_root: {translation: [x, y, z], rotation_wxyz: [w, x, y, z]}  # ... this
//     average_frames: 100         # geo with positions: frames the sensors' positions are
//                                 # averaged over before the fit (geo_average_frames)

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <string>

#include "core/pipeline/world_frame.hpp"
#include "drivers/station/station_config.hpp"
#include "drivers/station/yaml_reader.hpp"

namespace lidarfuse::station {

struct WorldConfig {
    core::WorldFrameParams params;  // kind, anchors (sensor indices), T_world_root
    std::string frame_id = "utm";   // geo: parent of the fused frame on rt/tf_static
};

// Reads `document["world"]` into `world` (root_sensor from `station`); sensor names in
// `positions` are looked up in `station`. Every problem goes to r.problems with its path.
void read_world_section(YamlReader& r, const YAML::Node& document, const StationConfig& station,
                        WorldConfig* world);

// The section of a whole file; throws ConfigError naming the file and listing every problem.
WorldConfig load_world_config(const std::filesystem::path& file, const StationConfig& station);

}  // namespace lidarfuse::station
