// The simulator's capture, decoded by the project's own ingest and placed with
// ground_truth.csv, lies on the scene's surfaces: with no motion, no traffic and no noise
// every point is within 1 mm of a scene triangle (quantisation to 1 mm gives <= 0.5 mm).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "drivers/sim/scene.hpp"
#include "tests/drivers/sim_decode.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

// Nearest-triangle distance through a uniform xy grid over the scene's triangles.
class SceneDistance {
public:
    explicit SceneDistance(const sim::Mesh& mesh) : mesh_(mesh) {
        cells_.resize(kN * kN);
        for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
            Eigen::Vector2f lo(1e9f, 1e9f), hi(-1e9f, -1e9f);
            for (int k = 0; k < 3; ++k) {
                lo = lo.cwiseMin(mesh.vertices[mesh.triangles[t][k]].head<2>());
                hi = hi.cwiseMax(mesh.vertices[mesh.triangles[t][k]].head<2>());
            }
            for (int i = cell(lo.x()); i <= cell(hi.x()); ++i) {
                for (int j = cell(lo.y()); j <= cell(hi.y()); ++j) cells_[i * kN + j].push_back(t);
            }
        }
    }
    double distance(const Eigen::Vector3d& p) const {
        double best = 1e9;
        for (const std::size_t t : cells_[cell(p.x()) * kN + cell(p.y())]) {
            const auto& tri = mesh_.triangles[t];
            best = std::min(best,
                            sim::point_triangle_distance(p, mesh_.vertices[tri[0]].cast<double>(),
                                                         mesh_.vertices[tri[1]].cast<double>(),
                                                         mesh_.vertices[tri[2]].cast<double>()));
        }
        return best;
    }

private:
    static constexpr int kN = 200;
    static constexpr double kCellM = 4.0;
    static int cell(double v) {
        return std::clamp(static_cast<int>(std::floor(v / kCellM)) + kN / 2, 0, kN - 1);
    }
    const sim::Mesh& mesh_;
    std::vector<std::vector<std::size_t>> cells_;
};

class SimGeometry : public ::testing::TestWithParam<const char*> {};

TEST_P(SimGeometry, NoiseFreePointsLieOnTheSceneWithinOneMillimetre) {
    const std::string scenario = GetParam();
    test::TempDir dir("sim_geometry");
    std::string log;
    const std::string cmd = test::tool_path() + " sim --scenario " + scenario + " --out " +
                            dir.path().string() +
                            " --sensors 2 --seconds 0.1 --mode 512x20 --no-motion --no-traffic "
                            "--noise-sigma-m 0 --threads 2";
    ASSERT_EQ(test::run_command(cmd, &log), 0) << log;

    const auto cap = simtest::decode_sim_output(dir.path());
    const auto scene = sim::build_scene({*sim::scenario_from_string(scenario), 2, 1});
    const SceneDistance dist(scene.mesh);
    EXPECT_GT(cap.pcap_stats.reassembled, 0u) << "datagrams should be IP-fragmented";
    for (const auto& [name, scans] : cap.scans) {
        SCOPED_TRACE(name);
        const auto& c = cap.counters.at(name);
        EXPECT_EQ(c.bad_size + c.bad_profile + c.crc_errors + c.late_packets + c.duplicate_packets +
                      c.bad_columns + c.frames_incomplete + c.resets,
                  0u);
        EXPECT_EQ(c.frames_complete, 2u);
        ASSERT_EQ(scans.size(), 2u);
        for (const auto& scan : scans) {
            EXPECT_DOUBLE_EQ(scan.completeness, 1.0);
            const auto* row = simtest::truth_row(cap.truth, name, scan.first_column_ns);
            ASSERT_NE(row, nullptr) << "no ground-truth row at the scan's timestamp";
            ASSERT_GT(scan.points_sensor.size(), 4000u);
            double worst = 0;
            for (const auto& p : scan.points_sensor)
                worst = std::max(worst, dist.distance(row->pose * p));
            EXPECT_LT(worst, 1e-3) << "farthest point from any scene surface, metres";
            RecordProperty(name + "_worst_mm", std::to_string(worst * 1e3));
            std::printf("%s frame %u: %zu points, worst %.3f mm\n", name.c_str(), scan.frame_id,
                        scan.points_sensor.size(), worst * 1e3);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Scenarios, SimGeometry,
                         ::testing::Values("curve", "straight", "intersection"));

}  // namespace
}  // namespace lidarfuse
