#pragma once
// Synthetic structured scenes for the registration tests: a ground plane, walls, boxes and
// poles sampled uniformly at random (seeded), so that all six degrees of freedom are
// constrained. Header-only; used by the core registration tests.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

namespace lidarfuse::test {

// `count` points uniformly on the parallelogram origin + s u + t v, s, t in [0, 1].
inline void sample_rectangle(std::mt19937& rng, const Eigen::Vector3d& origin,
                             const Eigen::Vector3d& u, const Eigen::Vector3d& v, int count,
                             std::vector<Eigen::Vector3d>* out) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int i = 0; i < count; ++i) out->push_back(origin + unit(rng) * u + unit(rng) * v);
}

// Points on the side of a vertical cylinder standing on z = 0.
inline void sample_pole(std::mt19937& rng, const Eigen::Vector3d& base, double radius_m,
                        double height_m, int count, std::vector<Eigen::Vector3d>* out) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int i = 0; i < count; ++i) {
        const double a = 2.0 * M_PI * unit(rng);
        out->push_back(base + Eigen::Vector3d(radius_m * std::cos(a), radius_m * std::sin(a),
                                              height_m * unit(rng)));
    }
}

// A closed box without its bottom, axis-aligned in its own frame, yawed by yaw_rad.
inline void sample_box(std::mt19937& rng, const Eigen::Vector3d& corner,
                       const Eigen::Vector3d& size, double yaw_rad, double points_per_m2,
                       std::vector<Eigen::Vector3d>* out) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d ex = R * Eigen::Vector3d(size.x(), 0, 0);
    const Eigen::Vector3d ey = R * Eigen::Vector3d(0, size.y(), 0);
    const Eigen::Vector3d ez(0, 0, size.z());
    auto face = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
        const int n = static_cast<int>(u.cross(v).norm() * points_per_m2);
        sample_rectangle(rng, o, u, v, n, out);
    };
    face(corner, ex, ez);
    face(corner, ey, ez);
    face(corner + ex, ey, ez);
    face(corner + ey, ex, ez);
    face(corner + ez, ex, ey);
}

// Ground 30 m x 30 m, three walls (one oblique), two boxes, five poles. ~6000 points at
// the default density.
inline std::vector<Eigen::Vector3d> make_structured_scene(std::mt19937& rng,
                                                          double points_per_m2 = 4.0) {
    std::vector<Eigen::Vector3d> pts;
    auto plane = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
        sample_rectangle(rng, o, u, v, static_cast<int>(u.cross(v).norm() * points_per_m2), &pts);
    };
    plane({-15, -15, 0}, {30, 0, 0}, {0, 30, 0});  // ground
    plane({12, -10, 0}, {0, 20, 0}, {0, 0, 4});    // wall facing -x
    plane({-10, -11, 0}, {18, 0, 0}, {0, 0, 5});   // wall facing +y
    plane({-14, 4, 0}, {6, 7, 0}, {0, 0, 3.5});    // oblique wall
    sample_box(rng, {3, 4, 0}, {2, 3, 1.5}, 0.0, points_per_m2 * 2, &pts);
    sample_box(rng, {-6, -3, 0}, {4, 2, 2.5}, 0.5, points_per_m2 * 2, &pts);
    const int pole_points = static_cast<int>(40 * points_per_m2);
    sample_pole(rng, {5, -5, 0}, 0.15, 5.0, pole_points, &pts);
    sample_pole(rng, {-3, 7, 0}, 0.15, 5.0, pole_points, &pts);
    sample_pole(rng, {8, 8, 0}, 0.2, 6.0, pole_points, &pts);
    sample_pole(rng, {-9, -8, 0}, 0.15, 4.0, pole_points, &pts);
    sample_pole(rng, {0, -2, 0}, 0.1, 3.0, pole_points, &pts);
    return pts;
}

inline void add_gaussian_noise(std::mt19937& rng, double sigma_m,
                               std::vector<Eigen::Vector3d>* pts) {
    std::normal_distribution<double> noise(0.0, sigma_m);
    for (auto& p : *pts) p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
}

inline std::vector<Eigen::Vector3d> transformed(const Eigen::Isometry3d& T,
                                                const std::vector<Eigen::Vector3d>& pts) {
    std::vector<Eigen::Vector3d> out;
    out.reserve(pts.size());
    for (const auto& p : pts) out.push_back(T * p);
    return out;
}

// A random rigid transform with |t| = translation_m and rotation angle = angle_rad about a
// random axis.
inline Eigen::Isometry3d random_transform(std::mt19937& rng, double translation_m,
                                          double angle_rad) {
    std::normal_distribution<double> g(0.0, 1.0);
    const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(angle_rad, axis).toRotationMatrix();
    T.translation() = translation_m * dir;
    return T;
}

}  // namespace lidarfuse::test
