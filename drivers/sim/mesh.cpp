#include "drivers/sim/mesh.hpp"

#include <array>
#include <cmath>
#include <map>

namespace lidarfuse::sim {

const MaterialProps& material_props(Material m) {
    // Albedos at 865 nm from typical lidar reflectivity tables (asphalt dark, vegetation
    // bright in the near infrared, white paint and retro-reflective sheeting brightest).
    static const MaterialProps kTable[] = {
        {0.12, 0.0, false},   // asphalt
        {0.60, 0.0, false},   // lane marking
        {0.30, 0.0, false},   // concrete
        {0.45, 0.0, false},   // grass
        {0.35, 0.0, false},   // facade
        {0.08, 0.0, false},   // glass
        {0.25, 0.0, false},   // bark
        {0.50, 0.55, false},  // foliage: more than half of the rays pass a crown's surface
        {0.40, 0.0, false},   // metal
        {0.90, 0.0, true},    // sign face
        {0.30, 0.0, false},   // car paint
        {0.40, 0.0, false},   // cloth
    };
    static_assert(sizeof(kTable) / sizeof(kTable[0]) == static_cast<int>(Material::kCount));
    return kTable[static_cast<int>(m)];
}

void Mesh::append(const Mesh& other) {
    const auto base = static_cast<std::uint32_t>(vertices.size());
    vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
    for (const auto& t : other.triangles) triangles.push_back(t.array() + base);
    materials.insert(materials.end(), other.materials.begin(), other.materials.end());
}

void Mesh::add_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c, Material m) {
    const auto base = static_cast<std::uint32_t>(vertices.size());
    vertices.push_back(a.cast<float>());
    vertices.push_back(b.cast<float>());
    vertices.push_back(c.cast<float>());
    triangles.emplace_back(base, base + 1, base + 2);
    materials.push_back(m);
}

void Mesh::add_quad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                    const Eigen::Vector3d& d, Material m) {
    const auto base = static_cast<std::uint32_t>(vertices.size());
    for (const auto* v : {&a, &b, &c, &d}) vertices.push_back(v->cast<float>());
    triangles.emplace_back(base, base + 1, base + 2);
    triangles.emplace_back(base, base + 2, base + 3);
    materials.push_back(m);
    materials.push_back(m);
}

void Mesh::add_box(const Eigen::Isometry3d& T_world_box, const Eigen::Vector3d& half_m, Material m,
                   bool with_bottom) {
    std::array<Eigen::Vector3d, 8> c;
    for (int i = 0; i < 8; ++i) {
        const Eigen::Vector3d local((i & 1) ? half_m.x() : -half_m.x(),
                                    (i & 2) ? half_m.y() : -half_m.y(),
                                    (i & 4) ? half_m.z() : -half_m.z());
        c[i] = T_world_box * local;
    }
    add_quad(c[0], c[1], c[5], c[4], m);  // -y
    add_quad(c[1], c[3], c[7], c[5], m);  // +x
    add_quad(c[3], c[2], c[6], c[7], m);  // +y
    add_quad(c[2], c[0], c[4], c[6], m);  // -x
    add_quad(c[4], c[5], c[7], c[6], m);  // top
    if (with_bottom) add_quad(c[0], c[2], c[3], c[1], m);
}

void Mesh::add_cylinder(const Eigen::Vector3d& base, double radius_m, double height_m, Material m,
                        int sides) {
    const Eigen::Vector3d top = base + Eigen::Vector3d(0, 0, height_m);
    for (int i = 0; i < sides; ++i) {
        const double a0 = 2 * M_PI * i / sides, a1 = 2 * M_PI * (i + 1) / sides;
        const Eigen::Vector3d d0(radius_m * std::cos(a0), radius_m * std::sin(a0), 0);
        const Eigen::Vector3d d1(radius_m * std::cos(a1), radius_m * std::sin(a1), 0);
        add_quad(base + d0, base + d1, top + d1, top + d0, m);
        add_triangle(top, top + d0, top + d1, m);
    }
}

void Mesh::add_ellipsoid(const Eigen::Vector3d& centre, const Eigen::Vector3d& radii_m, Material m,
                         int levels) {
    using Tri = std::array<Eigen::Vector3d, 3>;
    const Eigen::Vector3d px(1, 0, 0), nx(-1, 0, 0), py(0, 1, 0), ny(0, -1, 0), pz(0, 0, 1),
        nz(0, 0, -1);
    std::vector<Tri> tris = {{px, py, pz}, {py, nx, pz}, {nx, ny, pz}, {ny, px, pz},
                             {py, px, nz}, {nx, py, nz}, {ny, nx, nz}, {px, ny, nz}};
    for (int l = 0; l < levels; ++l) {
        std::vector<Tri> finer;
        finer.reserve(tris.size() * 4);
        for (const auto& t : tris) {
            const Eigen::Vector3d ab = (t[0] + t[1]).normalized(), bc = (t[1] + t[2]).normalized(),
                                  ca = (t[2] + t[0]).normalized();
            finer.push_back({t[0], ab, ca});
            finer.push_back({ab, t[1], bc});
            finer.push_back({ca, bc, t[2]});
            finer.push_back({ab, bc, ca});
        }
        tris.swap(finer);
    }
    for (const auto& t : tris) {
        add_triangle(centre + t[0].cwiseProduct(radii_m), centre + t[1].cwiseProduct(radii_m),
                     centre + t[2].cwiseProduct(radii_m), m);
    }
}

void Mesh::add_strip(const std::vector<Eigen::Vector3d>& left,
                     const std::vector<Eigen::Vector3d>& right, Material m) {
    for (std::size_t i = 0; i + 1 < left.size() && i + 1 < right.size(); ++i) {
        add_quad(right[i], right[i + 1], left[i + 1], left[i], m);
    }
}

double point_triangle_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                               const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
    // Ericson, Real-Time Collision Detection, 5.1.5: closest point by Voronoi regions.
    const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) return (p - a).norm();
    const Eigen::Vector3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) return (p - b).norm();
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + ab * (d1 / (d1 - d3)))).norm();
    const Eigen::Vector3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) return (p - c).norm();
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + ac * (d2 / (d2 - d6)))).norm();
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).norm();
    }
    const double denom = 1.0 / (va + vb + vc);
    return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

}  // namespace lidarfuse::sim
