#pragma once
// The inputs of registration_diagnose_bench: one frame per case folder, each sensor's cloud
// with the pose it is judged against (simulated truth, or a real rig's reference).

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "core/common/point_cloud.hpp"

namespace lidarfuse::bench {

struct DiagnoseFrame {
    std::vector<core::PointCloud> clouds;           // root first, like calibrate
    std::vector<Eigen::Isometry3d> T_world_sensor;  // truth at each scan's time
    std::vector<std::string> names;

    // The true (or reference) T_target_source between two sensors of the frame.
    Eigen::Isometry3d truth(std::size_t target, std::size_t source) const {
        return Eigen::Isometry3d(T_world_sensor[target].inverse() * T_world_sensor[source]);
    }
};

// A simulated capture folder (station.yaml, capture.pcap, ground_truth.csv): the first
// complete scan of every enabled sensor, with the truth `truth_shift_s` after its time.
// Otherwise a real rig folder: the root's cloud first, then every sensor it has a
// T_ROOT_NAME.txt reference to.
DiagnoseFrame load_diagnose_frame(const std::string& dir, double truth_shift_s);

}  // namespace lidarfuse::bench
