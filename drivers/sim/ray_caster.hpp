#pragma once
// Ray casting against the scene with Embree 3 (libembree-dev). The static scene is built
// once (high-quality BVH); road users live in a small per-window scene with two motion
// time steps (linear interpolation of their vertices between the window's start and end),
// so every column is cast against the agents at its own instant (ray time in [0, 1]).
// Why Embree: its BVH builders and SIMD traversal (SSE/AVX2) trace several million
// incoherent rays per second per core on this scene size, well beyond what a hand-written
// scalar BVH would reach in the time available, and Debian ships it.
//
// Thread safety: a committed StaticScene / DynamicScene is read-only; cast() may be called
// from any number of threads at once. Construction and destruction are not thread-safe
// with respect to the same object.

#include <embree3/rtcore.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "drivers/sim/mesh.hpp"
#include "drivers/sim/traffic.hpp"

namespace lidarfuse::sim {

// One Embree device per process is plenty; shared by the scenes created from it.
class RayDevice {
public:
    // `build_threads`: threads Embree may use to build BVHs (0 = all hardware threads).
    explicit RayDevice(int build_threads = 0);
    ~RayDevice();
    RayDevice(const RayDevice&) = delete;
    RayDevice& operator=(const RayDevice&) = delete;
    RTCDevice get() const { return device_; }

private:
    RTCDevice device_;
};

struct RayHit {
    bool hit = false;
    double distance_m = 0;   // along the (unit) direction from the ray origin
    Eigen::Vector3d normal;  // unit geometric normal facing the ray origin
    Material material = Material::kAsphalt;
    bool dynamic = false;  // hit a road user
};

class DynamicScene;

class StaticScene {
public:
    StaticScene(const RayDevice& device, const Mesh& mesh);
    ~StaticScene();
    StaticScene(const StaticScene&) = delete;
    StaticScene& operator=(const StaticScene&) = delete;

    // Nearest hit with t in [t_near, t_far] along unit direction `dir` from `origin`,
    // against the static scene and (when given) the road users at `time01` of the dynamic
    // scene's window. Static hits are refined in double precision against the hit
    // triangle's plane (Embree intersects in float).
    RayHit cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_near,
                double t_far, const DynamicScene* dynamic, float time01) const;
    const Mesh& mesh() const { return *mesh_; }

private:
    const Mesh* mesh_;
    RTCScene scene_;
};

class DynamicScene {
public:
    // Road-user boxes moving linearly from their t0 to their t1 pose over the window.
    DynamicScene(const RayDevice& device, const std::vector<MovingBox>& boxes);
    ~DynamicScene();
    DynamicScene(const DynamicScene&) = delete;
    DynamicScene& operator=(const DynamicScene&) = delete;
    RTCScene handle() const { return scene_; }
    bool empty() const { return materials_.empty(); }
    Material material(unsigned prim_id) const { return materials_[prim_id]; }

private:
    RTCScene scene_;
    std::vector<Material> materials_;  // per triangle
};

}  // namespace lidarfuse::sim
