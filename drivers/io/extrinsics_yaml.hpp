#pragma once
// extrinsics.yaml: every sensor's pose in the root frame, as `lidarfuse calibrate` and
// lidarfused write it:
//   root: lidar0
//   sensors:
//     - name: lidar1
//       registered: true
//       T_root_sensor: {translation: [x, y, z], rotation_wxyz: [w, x, y, z]}
// Metres; unit quaternion. Unregistered sensors are listed with registered: false and no
// pose. Written atomically (temporary file + rename): a reader never sees half a file.

#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace lidarfuse::io {

struct ExtrinsicsEntry {
    std::string name;
    bool registered = false;
    Eigen::Isometry3d T_root_sensor = Eigen::Isometry3d::Identity();
    // Extra scalar figures written under `quality:` (e.g. p2p_error_m, fitness).
    std::map<std::string, double> quality;
};

std::string extrinsics_to_yaml(const std::string& root, const std::vector<ExtrinsicsEntry>& sensors);
void write_extrinsics_yaml(const std::filesystem::path& file, const std::string& root,
                           const std::vector<ExtrinsicsEntry>& sensors);
// Reads what write_extrinsics_yaml wrote; throws naming the file and key on bad input.
std::vector<ExtrinsicsEntry> read_extrinsics_yaml(const std::filesystem::path& file, std::string* root);

}  // namespace lidarfuse::io
