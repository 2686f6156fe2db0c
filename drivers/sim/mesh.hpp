#pragma once
// Triangle meshes of the synthetic scene, with one material per triangle, and builders for
// the simple solids a street is made of. World frame: metres, z up, road surface at z = 0.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace lidarfuse::sim {

// Surface kinds; the sensor model reads reflectivity and transmission from them.
enum class Material : std::uint8_t {
    kAsphalt,
    kLaneMarking,
    kConcrete,  // curbs, sidewalks
    kGrass,
    kFacade,
    kGlass,
    kBark,
    kFoliage,   // tree crowns: partly transmissive
    kMetal,     // poles, sign backs, traffic light housings
    kSignFace,  // retro-reflective sign faces
    kCarPaint,
    kCloth,  // pedestrians, cyclists
    kCount
};

struct MaterialProps {
    double reflectivity;  // Lambertian albedo at 865 nm, 0..1
    double transmission;  // probability that a ray passes through a hit (foliage only)
    bool retro;           // retro-reflector: strong return, little dependence on incidence
};
const MaterialProps& material_props(Material m);

struct Mesh {
    std::vector<Eigen::Vector3f> vertices;
    std::vector<Eigen::Matrix<std::uint32_t, 3, 1>> triangles;
    std::vector<Material> materials;  // one per triangle

    std::size_t triangle_count() const { return triangles.size(); }
    void append(const Mesh& other);
    void add_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                      Material m);
    // Quad a-b-c-d (counter-clockwise seen from the outside) as two triangles.
    void add_quad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                  const Eigen::Vector3d& d, Material m);
    // Box with half extents `half_m` placed by `T_world_box` (centre at the box origin).
    void add_box(const Eigen::Isometry3d& T_world_box, const Eigen::Vector3d& half_m, Material m,
                 bool with_bottom = true);
    // Upright cylinder (z axis) from `base` with `sides` facets, closed at the top.
    void add_cylinder(const Eigen::Vector3d& base, double radius_m, double height_m, Material m,
                      int sides = 12);
    // Ellipsoid (crowns) centred at `centre`: a subdivided octahedron, `levels` 0..3.
    void add_ellipsoid(const Eigen::Vector3d& centre, const Eigen::Vector3d& radii_m, Material m,
                       int levels = 2);
    // Triangle fan for a flat strip between two polylines (same length) at their own z.
    void add_strip(const std::vector<Eigen::Vector3d>& left,
                   const std::vector<Eigen::Vector3d>& right, Material m);
};

// Closest distance from a point to a triangle (metres), for tests and checks.
double point_triangle_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                               const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace lidarfuse::sim
