#pragma once
// extrinsics.yaml: every sensor's pose in the root frame, as `lidarfuse calibrate` and
// lidarfused write it:
//   station: roadside-17          (optional)
//   root: lidar0
//   sensors:
//     - name: lidar1
//       registered: true
//       T_root_sensor: {translation: [x, y, z], rotation_wxyz: [w, x, y, z]}
//       quality: {points: 61234, ...}          (optional scalar figures)
//     - name: lidar2
//       registered: false
//       reason: no_consistent_candidate        (why there is no pose; never a made-up one)
//   pairs:                                     (optional: the registration's pair figures)
//     - {source: lidar1, target: lidar0, status: accepted, p2p_error_m: 0.04, ...}
// Metres; unit quaternion with w >= 0. Written atomically (temporary file + rename): a
// reader never sees half a file.

#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/pipeline/world_frame.hpp"

namespace lidarfuse::io {

struct ExtrinsicsEntry {
    std::string name;
    bool registered = false;
    Eigen::Isometry3d T_root_sensor = Eigen::Isometry3d::Identity();
    std::string reason;  // written only when not registered and non-empty
    // Extra scalar figures written under `quality:` (e.g. p2p_error_m, fitness).
    std::map<std::string, double> quality;
};

// One registered pair's outcome: `figures` are scalars such as p2p_error_m or inliers.
struct ExtrinsicsPair {
    std::string source;
    std::string target;
    std::string status;
    std::map<std::string, double> figures;
};

// The world frame the station publishes in (station.yaml `world:`, core/pipeline/world_frame.hpp),
// written by lidarfused:
//   world:
//     frame: road                       (road | geo | sensor)
//     fused_frame: lidarfuse/fused      (the fused frame's tf name)
//     T_fused_root: {translation: [...], rotation_wxyz: [...]}
//     world_frame: utm                  (geo only: the tf parent of the fused frame ...)
//     T_world_fused: {...}              (... and the static transform to it: the offset)
//     figures: {residual_rms_m: 0.012, ...}
// With it, every registered sensor also carries T_fused_sensor = T_fused_root *
// T_root_sensor (its pose in the published frame); T_root_sensor keeps its meaning.
struct ExtrinsicsWorld {
    std::string frame;
    std::string fused_frame;  // omitted when empty
    Eigen::Isometry3d T_fused_root = Eigen::Isometry3d::Identity();
    std::string world_frame;  // omitted (with T_world_fused) when empty
    Eigen::Isometry3d T_world_fused = Eigen::Isometry3d::Identity();
    std::map<std::string, double> figures;
};

// The block of a fixed world frame, as lidarfused, `lidarfuse fuse` and `lidarfuse calibrate`
// write it: `fused_frame` (may be empty: omitted), geo's `world_frame_id` and offset, and
// the estimate's figures (road and geo: sensors_used, and residual_rms_m, residual_max_m
// when measured: geo, and road refined on road points; road: root_height_m, road_points; a
// geo fit: frames_averaged).
ExtrinsicsWorld extrinsics_world(const core::WorldFrame& frame, const std::string& fused_frame,
                                 const std::string& world_frame_id);

struct ExtrinsicsDocument {
    std::string station;  // omitted when empty
    std::string root;
    std::vector<ExtrinsicsEntry> sensors;
    std::vector<ExtrinsicsPair> pairs;     // omitted when empty
    std::optional<ExtrinsicsWorld> world;  // omitted when absent
};

std::string extrinsics_to_yaml(const ExtrinsicsDocument& document);
void write_extrinsics_yaml(const std::filesystem::path& file, const ExtrinsicsDocument& document);
// Reads what write_extrinsics_yaml wrote; throws naming the file and key on bad input.
ExtrinsicsDocument read_extrinsics_document(const std::filesystem::path& file);

// The sensors only (what lidarfused keeps): same file format.
std::string extrinsics_to_yaml(const std::string& root,
                               const std::vector<ExtrinsicsEntry>& sensors);
void write_extrinsics_yaml(const std::filesystem::path& file, const std::string& root,
                           const std::vector<ExtrinsicsEntry>& sensors);
std::vector<ExtrinsicsEntry> read_extrinsics_yaml(const std::filesystem::path& file,
                                                  std::string* root);

}  // namespace lidarfuse::io
