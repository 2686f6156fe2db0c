#include "core/dynamics/background_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace lidarfuse::core {
namespace {

// Rays of an OS1-like 512 x 64 scan from 2 m above the ground at z = -2, a wall at 25 m,
// and optionally a "vehicle" (a 4 x 2 x 1.5 m box) centred at x = vehicle_x on y in [-1, 1].
std::vector<Eigen::Vector3d> scan(double vehicle_x, bool with_vehicle, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.03);
    std::vector<Eigen::Vector3d> points;
    for (int row = 0; row < 64; ++row) {
        const double el = (16.6 - row * 33.2 / 63) * M_PI / 180;
        for (int col = 0; col < 512; ++col) {
            const double az = col * 2 * M_PI / 512;
            const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                    std::sin(el));
            double t = 25.0 / std::cos(el);
            if (d.z() < 0) t = std::min(t, 2.0 / -d.z());
            if (with_vehicle && d.x() > 0) {
                // Front face of the box at x = vehicle_x - 2 (the side the sensor sees).
                const double tx = (vehicle_x - 2) / d.x();
                const Eigen::Vector3d p = d * tx;
                if (std::abs(p.y()) <= 1 && p.z() >= -2 && p.z() <= -0.5) t = std::min(t, tx);
            }
            points.push_back(d * (t + noise(rng)));
        }
    }
    return points;
}

// A vehicle driving through a lane marks that lane dynamic; the score fades once traffic
// stops, and the static scene never becomes dynamic.
TEST(BackgroundModel, LaneBecomesDynamicThenFades) {
    BackgroundModel model;
    model.set_reference(scan(0, false, 1));
    BackgroundUpdate update;
    std::size_t dynamic_seen = 0;
    for (int f = 0; f < 20; ++f) {
        const auto current = scan(8 + 0.2 * f, true, 10 + f);
        model.update(current, &update);
        dynamic_seen += update.num_dynamic;
        // The wall and far ground stay static.
        for (std::size_t i = 0; i < current.size(); ++i) {
            if (current[i].norm() > 20) {
                ASSERT_FALSE(update.dynamic[i]) << "frame " << f;
            }
        }
    }
    EXPECT_GT(dynamic_seen, 200u);
    // The lane the vehicle crossed keeps a raised score just after it leaves ...
    EXPECT_GT(model.score_at(Eigen::Vector3d(9.0, 0, -1)), 0.5);
    for (int f = 0; f < 40; ++f) model.update(scan(0, false, 100 + f), &update);
    // ... and fades once the lane stays empty.
    EXPECT_LT(model.score_at(Eigen::Vector3d(9.0, 0, -1)), 0.5);
    EXPECT_EQ(update.num_dynamic, 0u);
}

// A vehicle present at frame 0 that later leaves: its reference points are marked, so the
// registration target of the first frame loses them.
TEST(BackgroundModel, VehicleInTheReferenceFrameIsMarkedWhenItLeaves) {
    BackgroundModel model;
    const auto reference = scan(10, true, 1);
    model.set_reference(reference);
    BackgroundUpdate update;
    model.update(scan(0, false, 2), &update);
    std::size_t marked_on_vehicle = 0;
    for (std::size_t j = 0; j < reference.size(); ++j) {
        const auto& p = reference[j];
        if (update.reference_dynamic[j]) {
            // Only the face, and what shares its 0.5 m voxels, may be marked.
            ASSERT_NEAR(p.x(), 8.0, 0.55);
            ++marked_on_vehicle;
        }
    }
    EXPECT_GT(marked_on_vehicle, 20u);
}

// Every frame, a point is dynamic exactly when it changed now or its voxel's score is above
// the threshold: the per-frame filter of hot voxels never hides one, and a voxel that has
// faded below 1e-12 is forgotten (its score reads 0, as a voxel never raised).
TEST(BackgroundModel, DynamicFlagsFollowTheScoresAndFadedVoxelsAreForgotten) {
    BackgroundModelParams params;
    params.attenuation = 0.5;  // forgotten after ceil(log(1e-13) / log(0.5)) = 44 frames
    BackgroundModel model(params);
    const auto reference = scan(0, false, 1);
    model.set_reference(reference);
    BackgroundUpdate update;
    ChangeDetector detector(params.change);
    detector.set_reference(reference);
    ChangeDetectionResult changes;
    std::size_t hot_points = 0;
    for (int f = 0; f < 12; ++f) {
        const auto current = scan(6 + 0.5 * f, true, 10 + f);
        model.update(current, &update);
        detector.detect(current, &changes);
        for (std::size_t i = 0; i < current.size(); ++i) {
            const bool hot = model.score_at(current[i]) > params.dynamic_threshold;
            ASSERT_EQ(update.dynamic[i] != 0, changes.added[i] || hot)
                << "frame " << f << " point " << i;
            hot_points += hot && !changes.added[i];
        }
        for (std::size_t j = 0; j < reference.size(); ++j) {
            const bool hot = model.score_at(reference[j]) > params.dynamic_threshold;
            ASSERT_EQ(update.reference_dynamic[j] != 0, changes.removed[j] || hot) << "frame " << f;
        }
    }
    EXPECT_GT(hot_points, 50u);  // points flagged by their voxel alone were checked
    const Eigen::Vector3d lane(9.0, 0, -1);
    ASSERT_GT(model.score_at(lane), 0.5);
    const auto empty = scan(0, false, 50);
    for (int f = 0; f < 44; ++f) model.update(empty, &update);
    EXPECT_GT(model.score_at(lane), 0.0);
    EXPECT_LT(model.score_at(lane), 1e-11);
    model.update(empty, &update);
    model.update(empty, &update);
    EXPECT_EQ(model.score_at(lane), 0.0);
}

// Voxels forgotten while others are still raised: the survivors keep their scores. Model a
// saw a vehicle in one lane, then nothing, then one further out, whose voxels are raised
// while the first lane's are forgotten one frame after another; model b saw only the
// second. Once the first lane is forgotten both models must agree to the bit.
TEST(BackgroundModel, ForgettingSomeVoxelsLeavesTheOthersScoresAlone) {
    BackgroundModelParams params;
    params.attenuation = 0.5;  // forgotten after 44 frames without a raise
    BackgroundModel a(params), b(params);
    const auto reference = scan(0, false, 1);
    a.set_reference(reference);
    b.set_reference(reference);
    BackgroundUpdate ua, ub;
    const auto empty = scan(0, false, 50);
    for (int f = 0; f < 12; ++f) a.update(scan(6 + 0.5 * f, true, 10 + f), &ua);
    for (int f = 0; f < 36; ++f) a.update(empty, &ua);
    for (int f = 0; f < 48; ++f) b.update(empty, &ub);
    std::size_t compared = 0;
    for (int f = 0; f < 20; ++f) {
        // Frames 49-68: the first lane's voxels (raised at frames 1-12) go at frames 46-57.
        const auto current = scan(15 + 0.5 * f, true, 100 + f);
        a.update(current, &ua);
        b.update(current, &ub);
        if (f < 9) continue;
        ASSERT_EQ(ua.dynamic, ub.dynamic) << "frame " << f;
        ASSERT_EQ(ua.reference_dynamic, ub.reference_dynamic) << "frame " << f;
        for (const auto& p : current) {
            ASSERT_EQ(a.score_at(p), b.score_at(p)) << "frame " << f;
            compared += b.score_at(p) > params.dynamic_threshold;
        }
    }
    EXPECT_GT(compared, 100u);  // the second lane's voxels were among those compared
}

}  // namespace
}  // namespace lidarfuse::core
