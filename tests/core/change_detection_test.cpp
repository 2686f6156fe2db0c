#include "core/change_detection.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>

namespace lidarfuse::core {
namespace {

struct Box {
    Eigen::Vector3d min, max;
};

// Slab test: distance along the unit ray d from the origin to the box, if hit.
std::optional<double> hit_box(const Eigen::Vector3d& d, const Box& b) {
    double t0 = 0, t1 = 1e9;
    for (int k = 0; k < 3; ++k) {
        if (std::abs(d[k]) < 1e-12) {
            if (0 < b.min[k] || 0 > b.max[k]) return std::nullopt;
            continue;
        }
        double a = b.min[k] / d[k], c = b.max[k] / d[k];
        if (a > c) std::swap(a, c);
        t0 = std::max(t0, a);
        t1 = std::min(t1, c);
    }
    if (t0 > t1 || t0 <= 0) return std::nullopt;
    return t0;
}

// An OS1-like scan (1024 x 64, +-16.6 deg) from 2 m above a ground plane, inside a round
// courtyard of radius 25 m, with optional boxes; Gaussian range noise.
std::vector<Eigen::Vector3d> scan(const std::vector<Box>& boxes, unsigned seed, double sigma = 0.03) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    std::vector<Eigen::Vector3d> points;
    for (int row = 0; row < 64; ++row) {
        const double el = (16.6 - row * 33.2 / 63) * M_PI / 180;
        for (int col = 0; col < 1024; ++col) {
            const double az = col * 2 * M_PI / 1024;
            const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
            double t = 25.0 / std::cos(el);              // the wall
            if (d.z() < 0) t = std::min(t, 2.0 / -d.z());  // the ground at z = -2
            for (const auto& b : boxes) {
                if (auto h = hit_box(d, b)) t = std::min(t, *h);
            }
            points.push_back(d * (t + noise(rng)));
        }
    }
    return points;
}

const Box kCar{{9, -1, -2}, {13.5, 1, -0.5}};  // a car 9-13.5 m ahead, on the ground

TEST(ChangeDetection, IdenticalSceneWithNoiseFlagsNothing) {
    ChangeDetector detector;
    detector.set_reference(scan({kCar}, 1));
    ChangeDetectionResult result;
    detector.detect(scan({kCar}, 2), &result);
    EXPECT_EQ(result.num_added, 0u);
    EXPECT_EQ(result.num_removed, 0u);
}

TEST(ChangeDetection, ArrivingCarIsAddedAndWhatItHidesIsNotRemoved) {
    ChangeDetector detector;
    const auto reference = scan({}, 1);
    const auto current = scan({kCar}, 2);
    detector.set_reference(reference);
    ChangeDetectionResult result;
    detector.detect(current, &result);
    EXPECT_EQ(result.num_removed, 0u);  // the ground behind the car is occluded, not gone
    std::size_t car_points = 0, car_added = 0, false_added = 0;
    for (std::size_t i = 0; i < current.size(); ++i) {
        const auto& p = current[i];
        const bool on_car = p.x() > 8.9 && p.x() < 13.6 && std::abs(p.y()) < 1.1 && p.z() > -1.95;
        car_points += on_car;
        car_added += on_car && result.added[i];
        false_added += !on_car && result.added[i];
    }
    ASSERT_GT(car_points, 50u);
    // Points on the car's edges may see ground in their cone: most, not all, are flagged.
    EXPECT_GT(car_added, car_points * 7 / 10);
    EXPECT_EQ(false_added, 0u);
}

TEST(ChangeDetection, DepartedCarIsRemovedFromTheReference) {
    ChangeDetector detector;
    const auto reference = scan({kCar}, 3);
    detector.set_reference(reference);
    ChangeDetectionResult result;
    detector.detect(scan({}, 4), &result);
    EXPECT_EQ(result.num_added, 0u);
    std::size_t removed_on_car = 0, removed_elsewhere = 0;
    for (std::size_t j = 0; j < reference.size(); ++j) {
        const auto& p = reference[j];
        const bool on_car = p.x() > 8.9 && p.x() < 13.6 && std::abs(p.y()) < 1.1 && p.z() > -1.95;
        removed_on_car += on_car && result.removed[j];
        removed_elsewhere += !on_car && result.removed[j];
    }
    EXPECT_GT(removed_on_car, 50u);
    EXPECT_EQ(removed_elsewhere, 0u);
}

// Without a measurement in the cone there is no evidence: a new object against open sky
// (all rays above the wall here miss) is not flagged, and nothing crashes on empty input.
TEST(ChangeDetection, NoEvidenceNoFlagAndEmptyInputs) {
    ChangeDetector detector;
    ChangeDetectionResult result;
    detector.detect(scan({}, 1), &result);  // no reference yet
    EXPECT_EQ(result.num_added, 0u);
    detector.set_reference({});
    detector.detect(scan({kCar}, 1), &result);
    EXPECT_EQ(result.num_added, 0u);
    detector.set_reference(scan({}, 1));
    detector.detect({}, &result);
    EXPECT_EQ(result.num_removed, 0u);
    EXPECT_TRUE(result.added.empty());
    detector.detect({Eigen::Vector3d::Zero(), Eigen::Vector3d(NAN, 0, 0)}, &result);
    EXPECT_EQ(result.num_added, 0u);
}

TEST(SphericalRangeImage, WindowMinimumWrapsInAzimuth) {
    SphericalGridParams grid;
    grid.azimuth_bins = 16;
    grid.elevation_bins = 4;
    SphericalRangeImage image(grid);
    // One point just below azimuth 2*pi (last column) at 5 m, elevation 0.
    image.build({Eigen::Vector3d(5 * std::cos(-0.01), 5 * std::sin(-0.01), 0)});
    image.compute_window_min(1);
    int az = 0, el = 0;
    double r = 0;
    ASSERT_TRUE(image.cell_of(Eigen::Vector3d(1, 0.001, 0), &az, &el, &r));
    EXPECT_EQ(az, 0);
    EXPECT_NEAR(image.window_min(az, el), 5.0, 1e-9);  // seen across the wrap
    EXPECT_TRUE(std::isinf(image.window_min(8, el)));
}

}  // namespace
}  // namespace lidarfuse::core
