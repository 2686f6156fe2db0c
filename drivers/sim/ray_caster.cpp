#include "drivers/sim/ray_caster.hpp"

#include <limits>
#include <stdexcept>
#include <string>

namespace lidarfuse::sim {

namespace {

void check(RTCDevice device, const char* what) {
    const RTCError e = rtcGetDeviceError(device);
    if (e != RTC_ERROR_NONE) {
        throw std::runtime_error(std::string("sim: Embree error ") + std::to_string(e) + " in " +
                                 what);
    }
}

RTCRayHit make_ray(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_near, double t_far,
                   float time01) {
    RTCRayHit rh;
    rh.ray.org_x = static_cast<float>(o.x());
    rh.ray.org_y = static_cast<float>(o.y());
    rh.ray.org_z = static_cast<float>(o.z());
    rh.ray.dir_x = static_cast<float>(d.x());
    rh.ray.dir_y = static_cast<float>(d.y());
    rh.ray.dir_z = static_cast<float>(d.z());
    rh.ray.tnear = static_cast<float>(t_near);
    rh.ray.tfar = static_cast<float>(t_far);
    rh.ray.time = time01;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

}  // namespace

RayDevice::RayDevice(int build_threads)
    : device_(rtcNewDevice(build_threads > 0
                               ? ("verbose=0,threads=" + std::to_string(build_threads)).c_str()
                               : "verbose=0")) {
    if (!device_) throw std::runtime_error("sim: cannot create an Embree device");
}

RayDevice::~RayDevice() { rtcReleaseDevice(device_); }

StaticScene::StaticScene(const RayDevice& device, const Mesh& mesh) : mesh_(&mesh) {
    RTCDevice dev = device.get();
    scene_ = rtcNewScene(dev);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                          RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                          mesh.vertices.size()));
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        for (int k = 0; k < 3; ++k) v[3 * i + k] = mesh.vertices[i][k];
    }
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), mesh.triangles.size()));
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        for (int k = 0; k < 3; ++k) idx[3 * i + k] = mesh.triangles[i][k];
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(scene_, geom, 0);
    rtcReleaseGeometry(geom);
    rtcCommitScene(scene_);
    check(dev, "building the static scene");
}

StaticScene::~StaticScene() { rtcReleaseScene(scene_); }

RayHit StaticScene::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_near,
                         double t_far, const DynamicScene* dynamic, float time01) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh = make_ray(origin, dir, t_near, t_far, time01);
    rtcIntersect1(scene_, &ctx, &rh);
    RayHit out;
    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        const auto& tri = mesh_->triangles[rh.hit.primID];
        const Eigen::Vector3d a = mesh_->vertices[tri[0]].cast<double>();
        const Eigen::Vector3d b = mesh_->vertices[tri[1]].cast<double>();
        const Eigen::Vector3d c = mesh_->vertices[tri[2]].cast<double>();
        Eigen::Vector3d n = (b - a).cross(c - a).normalized();
        const double denom = n.dot(dir);
        out.hit = true;
        out.distance_m = rh.ray.tfar;
        if (std::abs(denom) > 1e-9) out.distance_m = n.dot(a - origin) / denom;  // refined
        out.normal = denom > 0 ? -n : n;
        out.material = mesh_->materials[rh.hit.primID];
    }
    if (dynamic && !dynamic->empty()) {
        RTCRayHit dh = make_ray(origin, dir, t_near, out.hit ? out.distance_m : t_far, time01);
        rtcIntersect1(dynamic->handle(), &ctx, &dh);
        if (dh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
            out.hit = true;
            out.dynamic = true;
            out.distance_m = dh.ray.tfar;
            Eigen::Vector3d n(dh.hit.Ng_x, dh.hit.Ng_y, dh.hit.Ng_z);
            n.normalize();
            out.normal = n.dot(dir) > 0 ? -n : n;
            out.material = dynamic->material(dh.hit.primID);
        }
    }
    return out;
}

DynamicScene::DynamicScene(const RayDevice& device, const std::vector<MovingBox>& boxes) {
    RTCDevice dev = device.get();
    scene_ = rtcNewScene(dev);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_LOW);
    if (boxes.empty()) {
        rtcCommitScene(scene_);
        return;
    }
    Mesh m0, m1;
    for (const auto& b : boxes) {
        m0.add_box(b.T_world_box_t0, b.half_m, b.material);
        m1.add_box(b.T_world_box_t1, b.half_m, b.material);
    }
    materials_ = m0.materials;
    RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryTimeStepCount(geom, 2);
    for (unsigned slot = 0; slot < 2; ++slot) {
        const Mesh& m = slot == 0 ? m0 : m1;
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, slot,
                                                              RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                              m.vertices.size()));
        for (std::size_t i = 0; i < m.vertices.size(); ++i) {
            for (int k = 0; k < 3; ++k) v[3 * i + k] = m.vertices[i][k];
        }
    }
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), m0.triangles.size()));
    for (std::size_t i = 0; i < m0.triangles.size(); ++i) {
        for (int k = 0; k < 3; ++k) idx[3 * i + k] = m0.triangles[i][k];
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(scene_, geom, 0);
    rtcReleaseGeometry(geom);
    rtcCommitScene(scene_);
    check(dev, "building the road-user scene");
}

DynamicScene::~DynamicScene() { rtcReleaseScene(scene_); }

}  // namespace lidarfuse::sim
