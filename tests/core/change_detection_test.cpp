#include "core/dynamics/change_detection.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
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
std::vector<Eigen::Vector3d> scan(const std::vector<Box>& boxes, unsigned seed,
                                  double sigma = 0.03) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    std::vector<Eigen::Vector3d> points;
    for (int row = 0; row < 64; ++row) {
        const double el = (16.6 - row * 33.2 / 63) * M_PI / 180;
        for (int col = 0; col < 1024; ++col) {
            const double az = col * 2 * M_PI / 1024;
            const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                    std::sin(el));
            double t = 25.0 / std::cos(el);                // the wall
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
constexpr double kNoRange = std::numeric_limits<double>::infinity();

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

// Rows come into use one band at a time: a row never used reads +infinity, a row used
// starts at +infinity, and so do the rows between it and the band used so far.
TEST(BandedImage, RowsOutsideTheBandReadInfinityAndNewRowsStartThere) {
    BandedImage image(6, 3);
    for (std::size_t cell = 0; cell < 18; ++cell) EXPECT_TRUE(std::isinf(image.at(cell)));
    image.row(2)[1] = 4.0;
    EXPECT_EQ(image.at(7), 4.0);
    EXPECT_TRUE(std::isinf(image.at(6)));
    image.row(4)[0] = 1.0;  // fills row 3 too
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(std::isinf(image.row(3)[c]));
    EXPECT_EQ(image.at(12), 1.0);
    EXPECT_EQ(image.at(7), 4.0);  // kept
    image.row(0)[2] = 2.0;        // below the band: fills row 1
    EXPECT_EQ(image.at(2), 2.0);
    for (std::size_t cell = 3; cell < 6; ++cell) EXPECT_TRUE(std::isinf(image.at(cell)));
    for (std::size_t cell = 15; cell < 18; ++cell) EXPECT_TRUE(std::isinf(image.at(cell)));
}

// A copy holds the band of its source and nothing of what it held before: rows of its old
// band outside the new one read +infinity, and a row used afterwards starts there.
TEST(BandedImage, AssignedCopyHoldsTheSourcesBandOnly) {
    BandedImage source(6, 3), copy(6, 3);
    copy.row(0)[0] = 9.0;
    copy.row(1)[1] = 9.0;
    source.row(3)[2] = 5.0;
    source.row(4)[0] = 6.0;
    copy.assign(source);
    for (std::size_t cell = 0; cell < 18; ++cell) {
        const double want = cell == 11 ? 5.0 : cell == 12 ? 6.0 : kNoRange;
        EXPECT_EQ(copy.at(cell), want) << "cell " << cell;
    }
    copy.row(1)[2] = 1.0;  // rows 1 and 2 join the band at +infinity
    EXPECT_EQ(copy.at(5), 1.0);
    EXPECT_EQ(copy.at(3), kNoRange);
    EXPECT_EQ(copy.at(8), kNoRange);
    EXPECT_EQ(copy.at(11), 5.0);
}

// The engine's threads share one scratch among the sensors they prepare. Two detectors on
// one scratch, made for another grid and used by the other detector's scans in between,
// flag exactly what each flags with a scratch of its own.
TEST(ChangeDetection, DetectorsSharingOneScratchFlagAsWithTheirOwn) {
    ChangeDetectionParams coarse;
    coarse.grid.azimuth_bins = 512;
    coarse.grid.elevation_bins = 96;
    ChangeDetector arriving(coarse), leaving(coarse), arriving_alone(coarse), leaving_alone(coarse);
    ChangeDetectionScratch shared;  // the default grid: refitted on first use
    arriving.set_reference(scan({}, 1), &shared);
    leaving.set_reference(scan({kCar}, 2), &shared);
    arriving_alone.set_reference(scan({}, 1));
    leaving_alone.set_reference(scan({kCar}, 2));
    for (unsigned frame = 0; frame < 2; ++frame) {
        ChangeDetectionResult a, l, a_alone, l_alone;
        arriving.detect(scan({kCar}, 3 + frame), &a, &shared);
        leaving.detect(scan({}, 5 + frame), &l, &shared);
        arriving_alone.detect(scan({kCar}, 3 + frame), &a_alone);
        leaving_alone.detect(scan({}, 5 + frame), &l_alone);
        EXPECT_GT(a.num_added, 100u);
        EXPECT_GT(l.num_removed, 50u);
        EXPECT_EQ(a.added, a_alone.added);
        EXPECT_EQ(a.removed, a_alone.removed);
        EXPECT_EQ(l.added, l_alone.added);
        EXPECT_EQ(l.removed, l_alone.removed);
    }
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

// Successive builds over different bands of rows: every window minimum equals the brute
// force over the cone, and nothing of an earlier scan is left behind.
TEST(SphericalRangeImage, WindowMinimumMatchesBruteForceAcrossRebuilds) {
    SphericalGridParams g;
    g.azimuth_bins = 64;
    g.elevation_bins = 24;
    SphericalRangeImage image(g);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (const auto& band : {std::pair{-10.0, 20.0}, {30.0, 55.0}, {-59.0, -40.0}, {-5.0, 5.0}}) {
        std::vector<Eigen::Vector3d> points;
        for (int i = 0; i < 300; ++i) {
            const double el = (band.first + (band.second - band.first) * unit(rng)) * M_PI / 180;
            const double az = 2 * M_PI * unit(rng);
            const double r = 1 + 50 * unit(rng);
            points.emplace_back(r * std::cos(el) * std::cos(az), r * std::cos(el) * std::sin(az),
                                r * std::sin(el));
        }
        for (int cone : {0, 1, 2}) {
            image.build(points);
            image.compute_window_min(cone);
            for (int e = 0; e < g.elevation_bins; ++e) {
                for (int a = 0; a < g.azimuth_bins; ++a) {
                    double want = std::numeric_limits<double>::infinity();
                    for (int de = -cone; de <= cone; ++de) {
                        const int ee = e + de;
                        if (ee < 0 || ee >= g.elevation_bins) continue;
                        for (int da = -cone; da <= cone; ++da) {
                            want = std::min(
                                want,
                                image.nearest((a + da + g.azimuth_bins) % g.azimuth_bins, ee));
                        }
                    }
                    ASSERT_EQ(image.window_min(a, e), want)
                        << "band " << band.first << " cone " << cone << " cell " << a << "," << e;
                }
            }
        }
    }
    // An empty scan leaves an empty image.
    image.build({});
    image.compute_window_min(1);
    for (int e = 0; e < g.elevation_bins; ++e) {
        for (int a = 0; a < g.azimuth_bins; ++a) {
            ASSERT_TRUE(std::isinf(image.nearest(a, e)));
            ASSERT_TRUE(std::isinf(image.window_min(a, e)));
        }
    }
}

// The cell by the definition: elevation and azimuth from asin and atan2, floored.
std::optional<std::pair<int, int>> reference_cell(const SphericalGridParams& g,
                                                  const Eigen::Vector3d& p) {
    const double r = p.norm();
    if (!(r > 1e-6) || !std::isfinite(r)) return std::nullopt;
    const double deg = M_PI / 180.0;
    const double el_scale = g.elevation_bins / ((g.max_elevation_deg - g.min_elevation_deg) * deg);
    const int e = static_cast<int>(std::floor(
        (std::asin(std::clamp(p.z() / r, -1.0, 1.0)) - g.min_elevation_deg * deg) * el_scale));
    if (e < 0 || e >= g.elevation_bins) return std::nullopt;
    double azimuth = std::atan2(p.y(), p.x());
    if (azimuth < 0) azimuth += 2.0 * M_PI;
    const int a =
        std::min(static_cast<int>(azimuth * g.azimuth_bins / (2.0 * M_PI)), g.azimuth_bins - 1);
    return std::make_pair(a, e);
}

TEST(SphericalGrid, CellsAreThoseOfAsinAndAtan2) {
    std::vector<SphericalGridParams> grids(4);
    grids[1].azimuth_bins = 2048;
    grids[1].elevation_bins = 64;
    grids[1].min_elevation_deg = -22.5;
    grids[1].max_elevation_deg = 22.5;
    grids[2].azimuth_bins = 512;
    grids[2].elevation_bins = 180;
    grids[2].min_elevation_deg = -90;
    grids[2].max_elevation_deg = 90;
    grids[3].azimuth_bins = 16;
    grids[3].elevation_bins = 3;
    std::mt19937 rng(7);
    std::normal_distribution<double> normal(0.0, 1.0);
    std::uniform_real_distribution<double> range(0.3, 200.0);
    for (const auto& g : grids) {
        SCOPED_TRACE(std::to_string(g.azimuth_bins) + "x" + std::to_string(g.elevation_bins));
        SphericalGrid grid(g);
        std::vector<Eigen::Vector3d> points;
        for (int i = 0; i < 200000; ++i) {
            const Eigen::Vector3d d(normal(rng), normal(rng), 0.3 * normal(rng));
            points.push_back(range(rng) * d.normalized());
        }
        // Axes, poles, signed zeros, the origin, a NaN, and rays a hair off the column
        // boundaries on both sides.
        for (double x : {-1.0, -0.0, 0.0, 1.0}) {
            for (double y : {-1.0, -0.0, 0.0, 1.0}) {
                for (double z : {-1.0, 0.0, 1.0}) points.emplace_back(x, y, z);
            }
        }
        points.emplace_back(std::nan(""), 0.0, 0.0);
        for (int k = 0; k < g.azimuth_bins; ++k) {
            for (double off : {-1e-9, 1e-9}) {
                const double angle = (k + off) * 2.0 * M_PI / g.azimuth_bins;
                points.emplace_back(10 * std::cos(angle), 10 * std::sin(angle), 0.1);
            }
        }
        int checked = 0;
        for (const auto& p : points) {
            int az = -1, el = -1;
            double r = 0;
            const bool in = grid.cell_of(p, &az, &el, &r);
            const auto want = reference_cell(g, p);
            ASSERT_EQ(in, want.has_value()) << p.transpose();
            if (!in) continue;
            ASSERT_EQ(az, want->first) << p.transpose();
            ASSERT_EQ(el, want->second) << p.transpose();
            ASSERT_DOUBLE_EQ(r, p.norm());
            ++checked;
        }
        EXPECT_GT(checked, 1000);
    }
}

}  // namespace
}  // namespace lidarfuse::core
