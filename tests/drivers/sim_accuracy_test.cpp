// With the default noise, swaying poles and traffic, the capture decoded by the ingest and
// placed with ground_truth.csv (interpolated to each column's timestamp) puts the road at
// z = 0 with the configured range noise, and two sensors agree on where the static scene
// is (planar patches seen by both coincide).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

#include "tests/drivers/sim_decode.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

constexpr double kSigmaM = 0.1 / 3.0;

struct WorldPoint {
    Eigen::Vector3d p;
    Eigen::Vector3d dir;  // world ray direction
};

// Every decoded point in the world frame, each column placed with the ground-truth pose
// interpolated to its timestamp.
std::map<std::string, std::vector<WorldPoint>> world_points(const simtest::DecodedCapture& cap) {
    std::map<std::string, std::vector<WorldPoint>> out;
    for (const auto& [name, scans] : cap.scans) {
        for (const auto& scan : scans) {
            // The last frame's columns lie after the last ground-truth row: nothing to
            // interpolate between, so it is left out.
            if (!simtest::truth_row(cap.truth, name, scan.first_column_ns + 50'000'000)) continue;
            std::map<std::int64_t, Eigen::Isometry3d> poses;
            for (std::size_t i = 0; i < scan.points_sensor.size(); ++i) {
                auto it = poses.find(scan.t_ns[i]);
                if (it == poses.end()) {
                    it =
                        poses
                            .emplace(scan.t_ns[i], simtest::truth_at(cap.truth, name, scan.t_ns[i]))
                            .first;
                }
                out[name].push_back({it->second * scan.points_sensor[i],
                                     it->second.linear() * scan.dirs_sensor[i]});
            }
        }
    }
    return out;
}

std::string run_sim(const test::TempDir& dir, const std::string& extra) {
    std::string log;
    const std::string cmd = test::tool_path() + " sim --scenario curve --out " +
                            dir.path().string() +
                            " --sensors 2 --seconds 0.3 --mode 512x20 --threads 2 " + extra;
    EXPECT_EQ(test::run_command(cmd, &log), 0) << log;
    return log;
}

TEST(SimAccuracy, RoadIsAtZeroWithTheConfiguredRangeNoise) {
    test::TempDir dir("sim_accuracy_road");
    run_sim(dir, "");  // motion, traffic and noise on (defaults)
    const auto cap = simtest::decode_sim_output(dir.path());
    for (const auto& [name, pts] : world_points(cap)) {
        SCOPED_TRACE(name);
        // Road of the curve: centre line radius 90 m around (0, 90), half width 10.5 m.
        double sum = 0, sum2 = 0;
        std::size_t n = 0;
        for (const auto& w : pts) {
            const double lateral = std::abs((w.p.head<2>() - Eigen::Vector2d(0, 90)).norm() - 90.0);
            // |z| < 0.12 m keeps road users out (their lowest parts are >= 0.2 m up) and
            // truncates the range error only beyond 0.12 / 0.15 = 0.8 m (24 sigma).
            if (lateral > 10.2 || std::abs(w.p.z()) > 0.12 || std::abs(w.dir.z()) < 0.15) continue;
            const double range_error = w.p.z() / w.dir.z();  // along the ray
            sum += range_error;
            sum2 += range_error * range_error;
            ++n;
        }
        ASSERT_GT(n, 5000u);
        const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
        std::printf("%s: %zu road points, range error mean %.2f mm, sigma %.2f mm\n", name.c_str(),
                    n, mean * 1e3, sd * 1e3);
        EXPECT_LT(std::abs(mean), 0.003);
        EXPECT_NEAR(sd, kSigmaM, 0.05 * kSigmaM);
    }
}

TEST(SimAccuracy, TwoSensorsSeeTheStaticSceneInTheSamePlace) {
    test::TempDir dir("sim_accuracy_overlap");
    run_sim(dir, "--no-traffic");  // motion and noise on
    const auto cap = simtest::decode_sim_output(dir.path());
    const auto pts = world_points(cap);
    ASSERT_EQ(pts.size(), 2u);
    using Key = std::tuple<int, int, int>;
    auto key = [](const Eigen::Vector3d& p) {
        return Key{static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y())),
                   static_cast<int>(std::floor(p.z()))};
    };
    std::map<Key, std::vector<Eigen::Vector3d>> a, b;
    for (const auto& w : pts.at("lidar0")) a[key(w.p)].push_back(w.p);
    for (const auto& w : pts.at("lidar1")) b[key(w.p)].push_back(w.p);
    std::vector<double> offsets;
    for (const auto& [k, pa] : a) {
        const auto it = b.find(k);
        if (pa.size() < 40 || it == b.end() || it->second.size() < 40) continue;
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const auto& p : pa) mean += p;
        mean /= static_cast<double>(pa.size());
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (const auto& p : pa) cov += (p - mean) * (p - mean).transpose();
        cov /= static_cast<double>(pa.size());
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
        if (es.eigenvalues()(0) > 0.003 || es.eigenvalues()(1) < 0.03) continue;  // not a plane
        const Eigen::Vector3d normal = es.eigenvectors().col(0);
        double off = 0;
        for (const auto& p : it->second) off += normal.dot(p - mean);
        offsets.push_back(std::abs(off / static_cast<double>(it->second.size())));
    }
    ASSERT_GE(offsets.size(), 20u) << "the two sensors should share planar surfaces";
    std::sort(offsets.begin(), offsets.end());
    const double median = offsets[offsets.size() / 2];
    const double p90 = offsets[offsets.size() * 9 / 10];
    std::printf("%zu shared planar voxels: |offset| median %.2f mm, 90th percentile %.2f mm\n",
                offsets.size(), median * 1e3, p90 * 1e3);
    EXPECT_LT(median, 0.01);
    EXPECT_LT(p90, 0.03);
}

}  // namespace
}  // namespace lidarfuse
