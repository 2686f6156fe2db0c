#pragma once
// The G-ICP pairs that gicp_pairs_bench writes and every comparison reads (ours, PCL's in
// bench/pcl, any other implementation's): OUT/pairs.txt and the clouds beside it.
//
// pairs.txt, one line per pair and setting:
//   name voxel_m k bound_m max_iterations eps target.f64 source.f64 T_init(16) T_ref(16)
// T_* are T_target_source, 4 x 4 row-major, metres; T_ref is the truth (simulated pairs) or
// the rig's published reference (real pairs); eps bounds both the rotation (rad) and the
// translation (m) of the last update. A cloud file holds a scan's points, sensor frame,
// metres, x y z as little-endian float64, nothing else.
//
// A result file (one per implementation and thread count), one line per pair:
//   name@voxel_m voxel_grid_ms tree_ms covariances_ms alignment_ms total_ms T(16)

#include <Eigen/Geometry>
#include <filesystem>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

namespace lidarfuse::bench {

struct GicpPair {
    std::string name;
    double voxel_m = 1.0;
    int k = 6;  // the covariances' neighbors
    double bound_m = 1.0;
    int max_iterations = 30;
    double eps = 1e-4;
    std::string target_file, source_file;  // in the pairs' folder
    Eigen::Isometry3d T_init = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_ref = Eigen::Isometry3d::Identity();
};

// Throws std::runtime_error naming the file and the line it cannot read.
std::vector<GicpPair> read_gicp_pairs(const std::filesystem::path& dir);
void write_gicp_pair(std::ostream& out, const GicpPair& pair);

std::vector<Eigen::Vector3d> read_pair_points(const std::filesystem::path& file);
void write_pair_points(const std::filesystem::path& file,
                       const std::vector<Eigen::Vector3d>& points);

// 16 numbers, row-major, each after a space.
void write_matrix(std::ostream& out, const Eigen::Isometry3d& T);
Eigen::Isometry3d read_matrix(std::istream& in);

// One line of a result file. `name` is the pair's name@voxel_m (result_name).
struct PairResult {
    double stage_ms[4] = {0.0, 0.0, 0.0, 0.0};  // voxel grid, tree, covariances, alignment
    double total_ms = 0.0;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();  // T_target_source
};
std::string result_name(const GicpPair& pair);
void write_pair_result(std::ostream& out, const GicpPair& pair, const PairResult& result);
// By result name; throws std::runtime_error naming the file and the line it cannot read.
std::map<std::string, PairResult> read_pair_results(const std::filesystem::path& file);

// What a pair's figures are grouped by: sim_temporal, sim_spatial, or the real pair's name.
std::string pair_kind(const std::string& name);

}  // namespace lidarfuse::bench
