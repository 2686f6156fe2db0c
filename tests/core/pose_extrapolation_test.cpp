// A pose carried ahead of the registered ones (pose_extrapolation.hpp), and when a sensor
// track trusts it (SensorTrack::predict_unregistered).
#include "core/pipeline/pose_extrapolation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include "core/common/se3.hpp"
#include "core/pipeline/sensor_track.hpp"

namespace lidarfuse::core {
namespace {

constexpr std::int64_t kPeriodNs = 50'000'000;  // 20 Hz

double rotation_between_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
    return rotation_angle_deg(a.linear(), b.linear());
}

// A pose moving as T0 exp(v t + a t^2 / 2): constant acceleration in T0's tangent space.
Eigen::Isometry3d accelerating(double t_s) {
    Eigen::Isometry3d T0 = Eigen::Isometry3d::Identity();
    T0.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    T0.translation() = Eigen::Vector3d(3, -2, 5);
    Vector6d v, a;
    v << 0.02, -0.01, 0.03, 0.2, 0.1, -0.05;  // rad/s, m/s
    a << -0.15, 0.1, 0.05, -0.8, 0.6, 0.2;    // rad/s^2, m/s^2
    return T0 * se3_exp(v * t_s + a * (0.5 * t_s * t_s));
}

// Poses of `motion` at frames first.., one every `stride` frames, `count` of them.
template <typename Motion>
std::vector<PoseSample> samples(Motion motion, int first, int stride, int count) {
    std::vector<PoseSample> out;
    for (int i = 0; i < count; ++i) {
        const std::int64_t frame = first + i * stride;
        out.push_back(PoseSample{frame, frame * kPeriodNs, motion(frame * kPeriodNs * 1e-9)});
    }
    return out;
}

// The newest pose's tangent space is where the fit is made: a trajectory that is a quadratic
// there is carried ahead exactly by order 2, and missed by about a h^2 / 2 by order 1.
TEST(PoseExtrapolation, ConstantAccelerationIsCarriedAheadExactly) {
    const auto newest_relative = [](double t_s) {
        const double t_last = 0.35;
        Vector6d v, a;
        v << 0.05, 0.02, -0.03, 0.3, -0.2, 0.1;
        a << 0.2, -0.1, 0.1, 1.0, 0.5, -0.4;
        const double tau = t_s - t_last;
        return accelerating(t_last) * se3_exp(v * tau + a * (0.5 * tau * tau));
    };
    const std::vector<PoseSample> poses = samples(newest_relative, 0, 1, 8);
    const std::int64_t ahead_ns = poses.back().t_ns + 3 * kPeriodNs;
    const Eigen::Isometry3d truth = newest_relative(ahead_ns * 1e-9);
    const Eigen::Isometry3d quadratic = extrapolate_pose(poses, ahead_ns, 2);
    EXPECT_LT((quadratic.translation() - truth.translation()).norm(), 1e-9);
    EXPECT_LT(rotation_between_deg(quadratic, truth), 1e-7);
    // Order 1 misses the acceleration: 1 m/s^2 over 0.15 s and a window behind, centimetres.
    const Eigen::Isometry3d linear = extrapolate_pose(poses, ahead_ns, 1);
    EXPECT_GT((linear.translation() - truth.translation()).norm(), 0.01);
}

TEST(PoseExtrapolation, TooFewPosesGiveTheNewest) {
    const std::vector<PoseSample> poses = samples(accelerating, 0, 1, 2);
    const Eigen::Isometry3d held = extrapolate_pose(poses, poses.back().t_ns + kPeriodNs, 2);
    EXPECT_TRUE(held.isApprox(poses.back().T_root_sensor));
    EXPECT_TRUE(extrapolate_pose({}, 0, 2).isApprox(Eigen::Isometry3d::Identity()));
}

// A track trusts the fit only after registered frames confirmed it, only within reach of the
// newest pose, and no longer once registered poses leave it (a knock, a glitch).
TEST(SensorTrack, PredictionIsTrustedOnlyWhereRegisteredFramesConfirmIt) {
    const FusionParams params;
    SensorTrack track(params);
    std::int64_t frame = 0;
    const auto register_frame = [&](const Eigen::Isometry3d& T) {
        track.finish_frame(frame, frame * kPeriodNs, T);
        ++frame;
    };
    const auto next_ns = [&](int ahead) { return (frame - 1 + ahead) * kPeriodNs; };
    for (int i = 0; i < 4; ++i) register_frame(accelerating(frame * kPeriodNs * 1e-9));
    EXPECT_FALSE(track.predict_unregistered(next_ns(1))) << "no check made yet";
    for (int i = 0; i < 4; ++i) register_frame(accelerating(frame * kPeriodNs * 1e-9));
    const std::optional<Eigen::Isometry3d> next = track.predict_unregistered(next_ns(1));
    ASSERT_TRUE(next);
    const Eigen::Isometry3d truth = accelerating(next_ns(1) * 1e-9);
    EXPECT_LT((next->translation() - truth.translation()).norm(), 1e-6);
    EXPECT_FALSE(track.predict_unregistered(next_ns(4))) << "beyond prediction_max_ahead_s";
    EXPECT_FALSE(track.predict_unregistered(next_ns(-1))) << "before the newest pose";

    // A knock: the registered pose 0.5 deg off the sway. The checks' RMS is over the bound
    // until enough smooth frames have followed it out of the last four checks.
    Eigen::Isometry3d knocked = accelerating(frame * kPeriodNs * 1e-9);
    knocked.linear() =
        knocked.linear() * Eigen::AngleAxisd(0.5 * M_PI / 180, Eigen::Vector3d::UnitZ());
    register_frame(knocked);
    EXPECT_FALSE(track.predict_unregistered(next_ns(1)));
    int frames_to_trust = 0;
    while (!track.predict_unregistered(next_ns(1)) && frames_to_trust < 20) {
        register_frame(accelerating(frame * kPeriodNs * 1e-9));
        ++frames_to_trust;
    }
    EXPECT_GE(frames_to_trust, 4);
    EXPECT_LT(frames_to_trust, 20);

    // Registered frames further apart than a prediction may reach: nothing is checked.
    frame += 3;
    register_frame(accelerating(frame * kPeriodNs * 1e-9));
    EXPECT_FALSE(track.predict_unregistered(next_ns(1)));

    track.reset();
    EXPECT_FALSE(track.predict_unregistered(next_ns(1)));
}

// The station's clock stepped back (its time source corrected, a capture replayed in a
// loop): the poses before the step are on another time line. The track fits the new one
// alone, and trusts it again once registered frames on it confirm it, as after a start.
TEST(SensorTrack, AClockSteppedBackStartsTheFitAgain) {
    const FusionParams params;
    SensorTrack track(params);
    constexpr std::int64_t kStepNs = 10'000'000'000;  // 10 s back
    std::int64_t frame = 0;
    std::int64_t offset_ns = -kStepNs;  // stamp = true time - offset
    const auto register_frame = [&] {
        track.finish_frame(frame, frame * kPeriodNs - offset_ns,
                           accelerating(static_cast<double>(frame * kPeriodNs) * 1e-9));
        ++frame;
    };
    const auto next_ns = [&] { return frame * kPeriodNs - offset_ns; };
    for (int i = 0; i < 8; ++i) register_frame();
    ASSERT_TRUE(track.predict_unregistered(next_ns()));

    offset_ns = 0;
    register_frame();
    EXPECT_FALSE(track.predict_unregistered(next_ns())) << "one pose on the new time line";
    int frames_to_trust = 1;
    while (!track.predict_unregistered(next_ns()) && frames_to_trust < 20) {
        register_frame();
        ++frames_to_trust;
    }
    EXPECT_LE(frames_to_trust, 8) << "the fit of a fresh start takes 4 poses and 4 checks";
    const std::optional<Eigen::Isometry3d> next = track.predict_unregistered(next_ns());
    ASSERT_TRUE(next);
    const Eigen::Isometry3d truth = accelerating(static_cast<double>(frame * kPeriodNs) * 1e-9);
    EXPECT_LT((next->translation() - truth.translation()).norm(), 1e-6);
    EXPECT_LT(rotation_between_deg(*next, truth), 1e-5);
}

}  // namespace
}  // namespace lidarfuse::core
