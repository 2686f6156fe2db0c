// What the thinned cloud (output.dds.points_voxel_size_m, core/pipeline/fused_cloud_voxels.hpp)
// saves a subscriber and costs the daemon's output thread: for each voxel size, the points
// and PointCloud2 bytes per cloud against the full cloud's, the bandwidth at 20 Hz, and the
// process CPU time of one thinning.
//
// Input: fused clouds as `lidarfuse fuse --save-cloud` writes them (PLY). Without arguments
// it simulates the demo's station (curve seed 1, 4 OS1-64, 3 s) and fuses it at voxel 1 m,
// saving frames 20, 40 and 59 (the world frame fixed, traffic on the road).
//
// Output: `name value unit` lines.
// Usage: fused_cloud_voxels_bench [ROUNDS] [CLOUD.ply ...]
#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "core/pipeline/fused_cloud_voxels.hpp"
#include "drivers/io/fused_cloud_file.hpp"

namespace {

namespace fs = std::filesystem;
constexpr double kPointStepBytes = 20.0;  // daemon/dds_messages.hpp: what one point costs on DDS
constexpr double kFramesPerS = 20.0;

double cpu_s() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

std::vector<fs::path> simulated_clouds() {
    const fs::path dir = fs::temp_directory_path() / "lidarfuse-voxels-bench";
    const std::string tool = LIDARFUSE_TOOL_PATH;
    const std::string d = dir.string();
    const std::string sim =
        tool + " sim --scenario curve --seed 1 --seconds 3 --out " + d + "/sim > /dev/null";
    const std::string fuse = tool + " fuse " + d + "/sim/capture.pcap --config " + d +
                             "/sim/station.yaml --out " + d +
                             "/fused --save-cloud 20 --save-cloud 40 --save-cloud 59 > /dev/null";
    if (!fs::exists(dir / "fused" / "fused_59.ply") &&
        (std::system(sim.c_str()) != 0 || std::system(fuse.c_str()) != 0)) {
        std::fprintf(stderr, "fused_cloud_voxels_bench: simulating or fusing into %s failed\n",
                     d.c_str());
        std::exit(1);
    }
    return {dir / "fused" / "fused_20.ply", dir / "fused" / "fused_40.ply",
            dir / "fused" / "fused_59.ply"};
}

}  // namespace

int main(int argc, char** argv) {
    const int rounds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 20;
    std::vector<fs::path> files;
    for (int i = 2; i < argc; ++i) files.emplace_back(argv[i]);
    if (files.empty()) files = simulated_clouds();
    std::vector<lidarfuse::core::FusedCloud> clouds;
    double full_points = 0;
    for (const auto& f : files) {
        clouds.push_back(lidarfuse::io::read_fused_cloud_ply(f));
        full_points += static_cast<double>(clouds.back().points.size());
    }
    full_points /= static_cast<double>(clouds.size());
    std::printf("voxels_clouds %zu clouds\n", clouds.size());
    std::printf("voxels_full_points %.0f points\n", full_points);
    std::printf("voxels_full_mb_per_s %.2f MB/s\n",
                full_points * kPointStepBytes * kFramesPerS * 1e-6);
    lidarfuse::core::FusedCloudVoxels voxels;
    lidarfuse::core::FusedCloud out;
    for (const double size : {0.1, 0.2, 0.5, 1.0}) {
        const std::string tag = "voxels_" + std::to_string(static_cast<int>(size * 100)) + "cm_";
        double points = 0;
        const double t0 = cpu_s();
        for (int r = 0; r < rounds; ++r) {
            for (const auto& c : clouds) {
                voxels.downsample(c, size, &out);
                points += static_cast<double>(out.points.size());
            }
        }
        const double calls = static_cast<double>(rounds) * static_cast<double>(clouds.size());
        const double ms = (cpu_s() - t0) * 1e3 / calls;
        points /= calls;
        std::printf("%spoints %.0f points\n", tag.c_str(), points);
        std::printf("%sshare %.3f of the full cloud\n", tag.c_str(), points / full_points);
        std::printf("%smb_per_s %.2f MB/s\n", tag.c_str(),
                    points * kPointStepBytes * kFramesPerS * 1e-6);
        std::printf("%scpu_ms %.3f ms per cloud\n", tag.c_str(), ms);
    }
    return 0;
}
