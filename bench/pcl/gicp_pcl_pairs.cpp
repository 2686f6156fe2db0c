#include "bench/pcl/gicp_pcl_pairs.hpp"

#include <pcl/filters/voxel_grid.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>

#include "bench/gicp_pair_files.hpp"
#include "bench/pcl/pcl_gicp_support.hpp"
#include "core/common/stopwatch.hpp"

namespace lidarfuse::bench {
namespace {

using PclCloud = pcl::PointCloud<pcl::PointXYZ>;
using PclTree = pcl::search::KdTree<pcl::PointXYZ>;

PclCloud::Ptr pcl_voxel_grid(const PclCloud::Ptr& cloud, double voxel_m) {
    pcl::VoxelGrid<pcl::PointXYZ> grid;
    grid.setLeafSize(static_cast<float>(voxel_m), static_cast<float>(voxel_m),
                     static_cast<float>(voxel_m));
    grid.setInputCloud(cloud);
    auto out = pcl::make_shared<PclCloud>();
    grid.filter(*out);
    return out;
}

PairResult pcl_pass(const GicpPair& p, const PclCloud::Ptr& target_in,
                    const PclCloud::Ptr& source_in) {
    PairResult pass;
    core::Stopwatch t;
    const PclCloud::Ptr target = pcl_voxel_grid(target_in, p.voxel_m);
    const PclCloud::Ptr source = pcl_voxel_grid(source_in, p.voxel_m);
    pass.stage_ms[0] = t.milliseconds();
    t.restart();
    auto target_tree = pcl::make_shared<PclTree>();
    auto source_tree = pcl::make_shared<PclTree>();
    target_tree->setInputCloud(target);
    source_tree->setInputCloud(source);
    pass.stage_ms[1] = t.milliseconds();
    CountingGicp gicp;
    gicp.setCorrespondenceRandomness(p.k);
    auto target_cov = pcl::make_shared<CountingGicp::MatricesVector>();
    auto source_cov = pcl::make_shared<CountingGicp::MatricesVector>();
    t.restart();
    gicp.covariances(target, target_tree, target_cov.get());
    gicp.covariances(source, source_tree, source_cov.get());
    pass.stage_ms[2] = t.milliseconds();
    gicp.setMaxCorrespondenceDistance(p.bound_m);
    gicp.setMaximumIterations(p.max_iterations);
    gicp.setTransformationEpsilon(p.eps);
    gicp.setRotationEpsilon(p.eps);
    PclCloud aligned;
    t.restart();
    gicp.setInputTarget(target);
    gicp.setInputSource(source);
    gicp.setSearchMethodTarget(target_tree, /*force_no_recompute=*/true);
    gicp.setSearchMethodSource(source_tree, /*force_no_recompute=*/true);
    gicp.setTargetCovariances(target_cov);
    gicp.setSourceCovariances(source_cov);
    gicp.align(aligned, p.T_init.matrix().cast<float>());
    pass.stage_ms[3] = t.milliseconds();
    pass.T = Eigen::Isometry3d(gicp.getFinalTransformation().cast<double>());
    pass.T.linear() = Eigen::Quaterniond(pass.T.linear()).normalized().toRotationMatrix();
    return pass;
}

}  // namespace

int run_pcl_pairs(const std::filesystem::path& out, int repetitions) {
    std::ofstream results(out / "pcl_t1.txt");
    results.precision(17);
    for (const GicpPair& p : read_gicp_pairs(out)) {
        const auto target = to_pcl(read_pair_points(out / p.target_file));
        const auto source = to_pcl(read_pair_points(out / p.source_file));
        PairResult best = pcl_pass(p, target, source);
        for (int r = 1; r < repetitions; ++r) {
            const PairResult pass = pcl_pass(p, target, source);
            for (int s = 0; s < 4; ++s)
                best.stage_ms[s] = std::min(best.stage_ms[s], pass.stage_ms[s]);
        }
        for (const double ms : best.stage_ms) best.total_ms += ms;
        write_pair_result(results, p, best);
        std::printf("gicp_pcl_pair_%s_voxel%s_total %.6g ms\n", p.name.c_str(),
                    std::to_string(p.voxel_m).c_str(), best.total_ms);
    }
    return 0;
}

}  // namespace lidarfuse::bench
