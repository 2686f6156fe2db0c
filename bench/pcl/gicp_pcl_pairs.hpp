#pragma once
// gicp_pcl_bench's `pairs` mode: PCL's own pipeline on the pairs that `gicp_pairs_bench
// write OUT` made (bench/gicp_pair_files.hpp), each with its k, bound, iterations and
// epsilons: pcl::VoxelGrid, the FLANN k-d tree, GICP's covariances, its alignment with those
// trees and covariances, each stage's wall time the fastest of `repetitions`, one thread.
// Writes the result file OUT/pcl_t1.txt, which `gicp_pairs_bench compare OUT ours_t1.txt
// pcl_t1.txt` sets beside ours stage by stage; prints each pair's total.

#include <filesystem>

namespace lidarfuse::bench {

int run_pcl_pairs(const std::filesystem::path& out, int repetitions);

}  // namespace lidarfuse::bench
