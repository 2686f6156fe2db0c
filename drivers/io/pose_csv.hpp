#pragma once
// ground_truth.csv and poses.csv: one row per sensor per frame,
//   frame,sensor,t_ns,x,y,z,qw,qx,qy,qz
// ground_truth.csv holds T_world_sensor (the simulator's world frame); poses.csv holds
// T_root_sensor (root = the root sensor at frame 0). Positions in metres, unit quaternions.
// The header is a contract other tools rely on: it is written and required exactly so.

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "core/evaluation/evaluation.hpp"

namespace lidarfuse::io {

inline constexpr const char* kPoseCsvHeader = "frame,sensor,t_ns,x,y,z,qw,qx,qy,qz";

struct PoseRecord {
    std::int64_t frame = 0;
    std::string sensor;
    std::int64_t t_ns = 0;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

// Throws std::runtime_error naming the file and line of the first bad row (wrong header,
// wrong column count, a field that is not a number, a quaternion far from unit length).
std::vector<PoseRecord> read_pose_csv(const std::filesystem::path& file);
std::vector<PoseRecord> parse_pose_csv(std::istream& in, const std::string& source_name);

// The records as per-sensor trajectories for core::evaluate_trajectories, every position
// moved by `offset_m` (e.g. geo's whole-metre offset, to put fused-frame poses in the
// world frame of a ground truth).
core::Trajectories to_trajectories(const std::vector<PoseRecord>& records,
                                   const Eigen::Vector3d& offset_m = Eigen::Vector3d::Zero());

// Writes the header (when asked) and rows with micrometre / 1e-9 quaternion precision.
void write_pose_csv_header(std::ostream& out);
void write_pose_csv_row(std::ostream& out, const PoseRecord& record);

// Writes a whole file atomically (temporary file + rename), so a reader never sees half.
void write_pose_csv(const std::filesystem::path& file, const std::vector<PoseRecord>& records);

}  // namespace lidarfuse::io
