#pragma once
// Synthetic scenes for the feature-registration tests and the benchmark (header only,
// seeded): surface samplers with exact normals, and a small ray caster that scans a scene
// of a bounded ground plane, yawed boxes (buildings, cars) and vertical cylinders (poles)
// with an OS1-64-like beam pattern from a given sensor pose, adding Gaussian range noise.
// The resulting clouds are in the sensor frame, as a real scan would be.

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/common/point_cloud.hpp"

namespace lidarfuse::testing {

// A yawed box standing on the ground. What the ray caster needs of it (the box frame and a
// bounding sphere) is computed here once rather than for every ray of every scan; it is
// fixed at construction, so a moved box is a new box.
struct SceneBox {
    SceneBox(const Eigen::Vector3d& base_centre, const Eigen::Vector3d& extent, double yaw)
        : centre(base_centre),
          size(extent),
          yaw_rad(yaw),
          R_box_world(Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix()),
          mid_centre(base_centre + Eigen::Vector3d(0, 0, 0.5 * extent.z())),
          bounding_radius2_m2(0.25 * extent.squaredNorm() * (1.0 + 1e-6) + 1e-9) {}

    Eigen::Vector3d centre;  // base centre on the ground (m)
    Eigen::Vector3d size;    // x, y, z extent before yaw (m)
    double yaw_rad = 0.0;
    Eigen::Matrix3d R_box_world;  // world directions into the box's axes
    Eigen::Vector3d mid_centre;   // the box frame's origin: centre at half height (m)
    // Squared radius of a sphere about mid_centre that holds the box, slightly enlarged so
    // that rounding never rejects a ray the exact test would accept (m^2).
    double bounding_radius2_m2;
};

struct ScenePole {
    Eigen::Vector2d centre;
    double radius_m = 0.15;
    double height_m = 6.0;
};

struct Scene {
    double ground_half_extent_m = 60.0;  // the ground is the square |x|,|y| <= this
    std::vector<SceneBox> boxes;
    std::vector<ScenePole> poles;
};

struct ScanPattern {
    int beams = 64;
    int columns = 512;
    double min_elevation_deg = -16.6;
    double max_elevation_deg = 16.6;
    double max_range_m = 80.0;
    double min_range_m = 1.0;
    double range_noise_sigma_m = 0.01;
};

inline Eigen::Isometry3d sensor_pose(double x, double y, double z, double yaw_deg,
                                     double pitch_down_deg, double roll_deg = 0.0) {
    const double d = M_PI / 180.0;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(x, y, z);
    // Yaw about world z, then pitch about the sensor's y axis (positive = looking down).
    T.linear() = (Eigen::AngleAxisd(yaw_deg * d, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(pitch_down_deg * d, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(roll_deg * d, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    return T;
}

// Smallest positive ray parameter hitting the scene, or +inf.
inline double cast_ray(const Scene& scene, const Eigen::Vector3d& o, const Eigen::Vector3d& dir) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    double best = kInf;
    if (dir.z() < -1e-9) {
        const double t = -o.z() / dir.z();
        const Eigen::Vector3d p = o + t * dir;
        if (t > 0.0 && std::abs(p.x()) <= scene.ground_half_extent_m &&
            std::abs(p.y()) <= scene.ground_half_extent_m) {
            best = t;
        }
    }
    const double dir_norm2 = dir.squaredNorm();
    for (const SceneBox& box : scene.boxes) {
        // Most rays pass far from most boxes: those that miss its bounding sphere skip it.
        const Eigen::Vector3d oc = box.mid_centre - o;
        const double along = oc.dot(dir);
        if (oc.squaredNorm() - along * along / dir_norm2 > box.bounding_radius2_m2) continue;
        // Ray in the box frame (origin at the box centre, axes yawed).
        const Eigen::Vector3d lo = box.R_box_world * (o - box.mid_centre);
        const Eigen::Vector3d ld = box.R_box_world * dir;
        double t_near = -kInf;
        double t_far = kInf;
        bool miss = false;
        for (int a = 0; a < 3 && !miss; ++a) {
            const double half = 0.5 * box.size[a];
            if (std::abs(ld[a]) < 1e-12) {
                if (std::abs(lo[a]) > half) miss = true;
                continue;
            }
            double t1 = (-half - lo[a]) / ld[a];
            double t2 = (half - lo[a]) / ld[a];
            if (t1 > t2) std::swap(t1, t2);
            t_near = std::max(t_near, t1);
            t_far = std::min(t_far, t2);
            if (t_near > t_far) miss = true;
        }
        if (!miss && t_near > 0.0 && t_near < best) best = t_near;
    }
    for (const ScenePole& pole : scene.poles) {
        const Eigen::Vector2d oc = o.head<2>() - pole.centre;
        const Eigen::Vector2d d2 = dir.head<2>();
        const double a = d2.squaredNorm();
        if (a < 1e-12) continue;
        const double b = 2.0 * oc.dot(d2);
        const double c = oc.squaredNorm() - pole.radius_m * pole.radius_m;
        const double disc = b * b - 4 * a * c;
        if (disc < 0.0) continue;
        const double t = (-b - std::sqrt(disc)) / (2 * a);
        const double z = o.z() + t * dir.z();
        if (t > 0.0 && z >= 0.0 && z <= pole.height_m && t < best) best = t;
    }
    return best;
}

// One scan of `scene` from T_world_sensor, in the sensor frame.
inline core::PointCloud scan_scene(const Scene& scene, const Eigen::Isometry3d& T_world_sensor,
                                   const ScanPattern& pattern, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, pattern.range_noise_sigma_m);
    core::PointCloud cloud;
    const Eigen::Vector3d origin = T_world_sensor.translation();
    const double d = M_PI / 180.0;
    for (int b = 0; b < pattern.beams; ++b) {
        const double el =
            (pattern.min_elevation_deg + (pattern.max_elevation_deg - pattern.min_elevation_deg) *
                                             b / std::max(1, pattern.beams - 1)) *
            d;
        for (int c = 0; c < pattern.columns; ++c) {
            const double az = 2.0 * M_PI * c / pattern.columns;
            const Eigen::Vector3d dir_sensor(std::cos(el) * std::cos(az),
                                             std::cos(el) * std::sin(az), std::sin(el));
            const double t = cast_ray(scene, origin, T_world_sensor.linear() * dir_sensor);
            const double range = t + noise(rng);
            if (!std::isfinite(t) || t > pattern.max_range_m || range < pattern.min_range_m)
                continue;
            cloud.points.push_back(range * dir_sensor);
        }
    }
    return cloud;
}

// A roadside-like scene: ground, buildings and parked vehicles of assorted sizes and yaws
// (no symmetry that would make two placements equivalent) and a few poles.
inline Scene street_scene() {
    Scene scene;
    scene.ground_half_extent_m = 60.0;
    auto box = [&](double x, double y, double sx, double sy, double sz, double yaw_deg) {
        scene.boxes.push_back(
            {Eigen::Vector3d(x, y, 0.0), Eigen::Vector3d(sx, sy, sz), yaw_deg * M_PI / 180.0});
    };
    box(-14.0, 16.0, 10.0, 7.0, 9.0, 5.0);
    box(4.0, 19.0, 12.0, 6.0, 6.0, -8.0);
    box(20.0, 14.0, 6.0, 9.0, 12.0, 20.0);
    box(-18.0, -17.0, 8.0, 8.0, 5.0, 35.0);
    box(10.0, -18.0, 14.0, 5.0, 7.0, -3.0);
    box(-4.0, 3.5, 4.5, 1.8, 1.5, 10.0);
    box(7.0, -4.0, 4.2, 1.9, 1.6, -5.0);
    box(-9.0, -5.0, 10.0, 2.5, 3.5, 2.0);
    box(15.0, 2.0, 2.0, 2.0, 2.5, 45.0);
    box(-20.0, 2.0, 1.0, 6.0, 1.2, 0.0);
    scene.poles.push_back({Eigen::Vector2d(-6.0, 9.0), 0.2, 6.0});
    scene.poles.push_back({Eigen::Vector2d(3.0, 10.0), 0.15, 4.0});
    scene.poles.push_back({Eigen::Vector2d(12.0, -9.0), 0.25, 7.0});
    scene.poles.push_back({Eigen::Vector2d(-13.0, -9.5), 0.15, 3.0});
    scene.poles.push_back({Eigen::Vector2d(22.0, -5.0), 0.2, 5.0});
    return scene;
}

// Points on a rectangle spanned by `a` and `b` from `corner`, spacing `step_m`, with the
// given unit normal.
inline void sample_rectangle(const Eigen::Vector3d& corner, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, double step_m, const Eigen::Vector3d& normal,
                             core::PointCloud* cloud) {
    const int na = std::max(1, static_cast<int>(std::round(a.norm() / step_m)));
    const int nb = std::max(1, static_cast<int>(std::round(b.norm() / step_m)));
    for (int i = 0; i <= na; ++i) {
        for (int j = 0; j <= nb; ++j) {
            cloud->points.push_back(corner + a * (double(i) / na) + b * (double(j) / nb));
            cloud->normals.push_back(normal);
        }
    }
}

// The five visible faces (no bottom) of an axis-aligned box on the ground, outward normals.
inline void sample_box(const Eigen::Vector3d& min_corner, const Eigen::Vector3d& size,
                       double step_m, core::PointCloud* cloud) {
    const Eigen::Vector3d x(size.x(), 0, 0), y(0, size.y(), 0), z(0, 0, size.z());
    const Eigen::Vector3d& c = min_corner;
    sample_rectangle(c + z, x, y, step_m, Eigen::Vector3d::UnitZ(), cloud);
    sample_rectangle(c, x, z, step_m, -Eigen::Vector3d::UnitY(), cloud);
    sample_rectangle(c + y, x, z, step_m, Eigen::Vector3d::UnitY(), cloud);
    sample_rectangle(c, y, z, step_m, -Eigen::Vector3d::UnitX(), cloud);
    sample_rectangle(c + x, y, z, step_m, Eigen::Vector3d::UnitX(), cloud);
}

}  // namespace lidarfuse::testing

namespace lidarfuse::testing {

// Four roadside sensors in street_scene(): 5-6 m high, tilted down 6-12 degrees, with
// relative yaws up to 180 degrees; every one overlaps every other.
inline std::vector<Eigen::Isometry3d> street_sensor_poses() {
    return {sensor_pose(0.0, 0.0, 6.0, 0.0, 8.0), sensor_pose(8.0, 6.0, 5.0, 180.0, 6.0, 1.0),
            sensor_pose(-11.0, -2.0, 5.5, -100.0, 10.0),
            sensor_pose(3.0, -11.0, 6.0, 75.0, 12.0, -1.5)};
}

}  // namespace lidarfuse::testing
