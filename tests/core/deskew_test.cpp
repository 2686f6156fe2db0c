#include "core/deskew.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace lidarfuse::core {
namespace {

Eigen::Isometry3d pose_at(double t) {
    // A pole head swaying: 0.5 m/s sideways, 2 deg/s about x, plus a small yaw rate.
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(0.035 * t, Eigen::Vector3d::UnitX()) *
                  Eigen::AngleAxisd(0.01 * t, Eigen::Vector3d::UnitZ()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.1, 0.5 * t, 6.0);
    return T;
}

// World points seen by a moving sensor at different instants come back, after deskew, at
// the place the sensor at t_ref would have seen them.
TEST(Deskew, ConstantTwistRestoresTheReferenceFrame) {
    const double t_ref = 1.0;
    std::vector<Eigen::Vector3d> world, points;
    std::vector<float> dt;
    for (int col = 0; col < 1024; ++col) {
        const double t = t_ref + col * 0.05 / 1024;
        const Eigen::Vector3d w(10 * std::cos(col * 0.006), 10 * std::sin(col * 0.006), 0.0);
        world.push_back(w);
        points.push_back(pose_at(t).inverse() * w);  // measured in the sensor frame at t
        dt.push_back(static_cast<float>(t - t_ref));
    }
    // The motion model: twist from two earlier poses, as the engine does.
    const Vector6d xi = body_twist_per_s(pose_at(t_ref - 0.05), pose_at(t_ref), 0.05);
    double before = 0, after = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        before = std::max(before, (pose_at(t_ref) * points[i] - world[i]).norm());
    }
    deskew_points(xi, dt, &points);
    for (std::size_t i = 0; i < points.size(); ++i) {
        after = std::max(after, (pose_at(t_ref) * points[i] - world[i]).norm());
    }
    EXPECT_GT(before, 0.02);  // 2.5 cm smear over the sweep without deskew
    EXPECT_LT(after, 2e-4);   // only the model's second-order error remains
}

TEST(Deskew, ZeroTwistOrMismatchedTimesLeavePointsAlone) {
    std::vector<Eigen::Vector3d> points = {{1, 2, 3}, {4, 5, 6}};
    const auto copy = points;
    deskew_points(Vector6d::Zero(), {0.01f, 0.02f}, &points);
    EXPECT_EQ(points, copy);
    Vector6d xi = Vector6d::Zero();
    xi(3) = 1.0;
    deskew_points(xi, {0.01f}, &points);  // one time for two points: ignored
    EXPECT_EQ(points, copy);
    EXPECT_TRUE(body_twist_per_s(pose_at(0), pose_at(1), 0.0).isZero());
}

}  // namespace
}  // namespace lidarfuse::core
