#include "core/pipeline/world_frame.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include "core/pipeline/initial_registration_job.hpp"
#include "core/preprocess/normals.hpp"
#include "core/registration/kabsch.hpp"

namespace lidarfuse::core {

const char* to_string(WorldFrameKind kind) {
    switch (kind) {
        case WorldFrameKind::kRoad:
            return "road";
        case WorldFrameKind::kGeo:
            return "geo";
        case WorldFrameKind::kSensor:
            return "sensor";
    }
    return "unknown";
}

std::optional<WorldFrameKind> world_frame_kind_from(const std::string& name) {
    for (const auto kind : {WorldFrameKind::kRoad, WorldFrameKind::kGeo, WorldFrameKind::kSensor}) {
        if (name == to_string(kind)) return kind;
    }
    return std::nullopt;
}

namespace {

// The fused frame of a plane n . x + d = 0 (root frame, n unit and up): z = n, origin the
// root's foot on the plane, x the root's x axis projected onto it.
Eigen::Isometry3d road_frame_in_root(const Eigen::Vector3d& n, double d,
                                     const Eigen::Isometry3d& root_pose) {
    const Eigen::Vector3d p = root_pose.translation();
    const Eigen::Vector3d origin = p - (n.dot(p) + d) * n;
    Eigen::Vector3d x = root_pose.linear().col(0);
    x -= x.dot(n) * n;
    if (x.norm() < 1e-6) x = n.unitOrthogonal();  // a root looking straight down
    x.normalize();
    Eigen::Isometry3d T_root_fused = Eigen::Isometry3d::Identity();
    T_root_fused.linear().col(0) = x;
    T_root_fused.linear().col(1) = n.cross(x);
    T_root_fused.linear().col(2) = n;
    T_root_fused.translation() = origin;
    return T_root_fused;
}

Eigen::Isometry3d translation(const Eigen::Vector3d& t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = t;
    return T;
}

// The geo fused frame: the world frame shifted by T_world_root's translation rounded to
// `step` (the large offset stays in T_world_fused, the fused coordinates stay small).
void split_offset(const Eigen::Isometry3d& T_world_root, double step, WorldFrame* f) {
    Eigen::Vector3d offset = T_world_root.translation();
    if (step > 0) offset = (offset / step).array().round().matrix() * step;
    f->T_world_fused = translation(offset);
    f->T_fused_root = translation(-offset) * T_world_root;
}

// A plane n . x + d = 0 (root frame, n unit and up).
struct RoadPlane {
    Eigen::Vector3d n;
    double d = 0.0;
};

// The sensors' planes in the root frame, weighted by their inliers: n_i = R_i up_i through
// q_i = t_i - h_i n_i; normals sign-aligned with the root's up. None when no sensor found a
// plane; counts the planes used in num_sensors.
std::optional<RoadPlane> combine_sensor_planes(const std::vector<RoadPlaneObservation>& sensors,
                                               const Eigen::Vector3d& root_up,
                                               std::size_t* num_sensors) {
    Eigen::Vector3d n_sum = Eigen::Vector3d::Zero();
    double weight = 0.0;
    std::vector<std::pair<Eigen::Vector3d, double>> feet;  // q_i, w_i
    for (const auto& s : sensors) {
        if (!s.ground.found) continue;
        Eigen::Vector3d n = s.T_root_sensor.linear() * s.ground.up;
        if (n.dot(root_up) < 0) n = -n;
        const double w = static_cast<double>(std::max<std::size_t>(1, s.ground.num_inliers));
        n_sum += w * n;
        weight += w;
        feet.emplace_back(s.T_root_sensor.translation() - s.ground.sensor_height_m * n, w);
        ++*num_sensors;
    }
    if (*num_sensors == 0) return std::nullopt;
    RoadPlane plane;
    plane.n = n_sum.normalized();
    for (const auto& [q, w] : feet) plane.d -= w * plane.n.dot(q) / weight;
    return plane;
}

// Point i of the cloud (root frame) when it is static and within band_m of the plane.
bool static_point_in_band(const FusedCloud& cloud, std::size_t i, const RoadPlane& plane,
                          double band_m, Eigen::Vector3d* p) {
    if (i < cloud.dynamic.size() && cloud.dynamic[i]) return false;
    *p = cloud.points[i].cast<double>();
    return !(std::abs(plane.n.dot(*p) + plane.d) > band_m);  // a NaN distance counts in
}

// The plane refitted by PCA to the static points within band_m of it, with their count
// and rms distance (m); none when fewer than min_points.
struct BandFit {
    RoadPlane plane;
    std::size_t count = 0;
    double rms_m = 0.0;
};

std::optional<BandFit> fit_band(const FusedCloud& cloud, const RoadPlane& plane, double band_m,
                                std::size_t min_points) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    std::size_t count = 0;
    Eigen::Vector3d p;
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
        if (!static_point_in_band(cloud, i, plane, band_m, &p)) continue;
        mean += p;
        ++count;
    }
    if (count < min_points) return std::nullopt;
    mean /= static_cast<double>(count);
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
        if (!static_point_in_band(cloud, i, plane, band_m, &p)) continue;
        scatter += (p - mean) * (p - mean).transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
    BandFit fit;
    fit.plane.n = solver.eigenvectors().col(0).normalized();
    if (fit.plane.n.dot(plane.n) < 0) fit.plane.n = -fit.plane.n;
    fit.plane.d = -fit.plane.n.dot(mean);
    fit.count = count;
    fit.rms_m = std::sqrt(std::max(0.0, solver.eigenvalues()(0)) / static_cast<double>(count));
    return fit;
}

// Refinement on the fused cloud's static points in shrinking bands, until a band holds too
// few; the number of bands that refitted the plane.
std::size_t refine_on_cloud(const FusedCloud& cloud, const RoadFrameParams& params,
                            RoadPlane* plane, WorldFrame* f) {
    std::size_t rounds = 0;
    for (const double band : params.bands_m) {
        const std::optional<BandFit> fit = fit_band(cloud, *plane, band, params.min_points);
        if (!fit) break;
        *plane = fit->plane;
        f->num_road_points = fit->count;
        f->residual_rms_m = fit->rms_m;
        f->residual_max_m = band;
        ++rounds;
    }
    return rounds;
}

// A station of one sensor has no initial registration to take planes from: the root's road
// plane from a frame's static points (root frame = its sensor frame at the first frame);
// about 50 ms for 50k points.
RoadPlaneObservation root_plane_of(const FusedCloud& cloud) {
    PointCloud root_cloud;
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
        if (i >= cloud.dynamic.size() || !cloud.dynamic[i]) {
            root_cloud.points.push_back(cloud.points[i].cast<double>());
        }
    }
    NormalParams np;
    np.compute_covariances = false;
    if (root_cloud.points.size() >= 10) estimate_normals_covariances(&root_cloud, np);
    RoadPlaneObservation o;
    if (root_cloud.normals.size() == root_cloud.points.size()) {
        o.ground = estimate_ground_plane(root_cloud.points, root_cloud.normals);
    }
    return o;
}

}  // namespace

WorldFrame estimate_road_frame(const std::vector<RoadPlaneObservation>& sensors,
                               const Eigen::Isometry3d& root_pose, const FusedCloud* cloud,
                               const RoadFrameParams& params) {
    WorldFrame f;
    f.kind = WorldFrameKind::kRoad;
    std::optional<RoadPlane> plane =
        combine_sensor_planes(sensors, root_pose.linear().col(2), &f.num_sensors);
    if (!plane) {
        f.note = "no road plane found by any registered sensor";
        return f;
    }
    f.note = "road plane from " + std::to_string(f.num_sensors) + " sensor plane(s)";
    if (cloud && refine_on_cloud(*cloud, params, &*plane, &f) > 0) {
        f.note +=
            ", refined on " + std::to_string(f.num_road_points) + " road points of the fused cloud";
    }
    const Eigen::Isometry3d T_root_fused = road_frame_in_root(plane->n, plane->d, root_pose);
    f.T_fused_root = T_root_fused.inverse();
    f.root_height_m = plane->n.dot(root_pose.translation()) + plane->d;
    f.fixed = true;
    return f;
}

std::vector<RoadPlaneObservation> road_planes_of(const InitialRegistrationResult& result,
                                                 const Eigen::Isometry3d& T_root0_root) {
    std::vector<RoadPlaneObservation> planes;
    for (std::size_t k = 0; k < result.sensors.size(); ++k) {
        const auto& r = result.sensors[k];
        if (k != 0 && !r.registered) continue;  // k = 0: the root
        planes.push_back({T_root0_root * r.T_root_sensor, r.ground});
    }
    return planes;
}

WorldFrame road_frame_or_root_frame(const std::vector<RoadPlaneObservation>& sensors,
                                    const Eigen::Isometry3d& root_pose, const FusedCloud* cloud,
                                    const RoadFrameParams& params) {
    WorldFrame f = estimate_road_frame(sensors, root_pose, cloud, params);
    if (!f.fixed) {
        f.note += "; the fused frame is the root sensor's (as world.frame: sensor)";
        f.T_fused_root = Eigen::Isometry3d::Identity();
        f.fixed = true;
    }
    return f;
}

WorldFrame fit_geo_frame(const std::vector<Eigen::Vector3d>& positions_root,
                         const std::vector<Eigen::Vector3d>& positions_world,
                         double offset_step_m) {
    WorldFrame f;
    f.kind = WorldFrameKind::kGeo;
    if (positions_root.size() != positions_world.size() || positions_root.size() < 3) {
        f.note = "geo: need the positions of at least 3 sensors with a pose";
        return f;
    }
    // Kabsch on coordinates relative to the first world position: the fit's sums stay small.
    const Eigen::Vector3d base = positions_world.front();
    std::vector<Eigen::Vector3d> local;
    for (const auto& p : positions_world) local.push_back(p - base);
    const KabschResult k = estimate_rigid_transform(positions_root, local);
    if (!k.valid) {
        f.note = "geo: the sensors' positions lie on a line; the rotation about it is unknown";
        return f;
    }
    const Eigen::Isometry3d T_world_root = translation(base) * k.T_target_source;
    double sum = 0.0;
    for (std::size_t i = 0; i < positions_root.size(); ++i) {
        const double r = (k.T_target_source * positions_root[i] - local[i]).norm();
        f.anchor_residuals_m.push_back(r);
        f.residual_max_m = std::max(f.residual_max_m, r);
        sum += r * r;
    }
    f.residual_rms_m = std::sqrt(sum / static_cast<double>(positions_root.size()));
    f.num_sensors = positions_root.size();
    split_offset(T_world_root, offset_step_m, &f);
    f.fixed = true;
    f.note = "geo: T_world_root fitted to " + std::to_string(f.num_sensors) + " sensor positions";
    return f;
}

WorldFrame geo_frame_from(const Eigen::Isometry3d& T_world_root, double offset_step_m) {
    WorldFrame f;
    f.kind = WorldFrameKind::kGeo;
    split_offset(T_world_root, offset_step_m, &f);
    f.fixed = true;
    f.note = "geo: T_world_root given";
    return f;
}

WorldFrameTracker::WorldFrameTracker(const WorldFrameParams& params, std::size_t num_sensors)
    : params_(params),
      num_sensors_(num_sensors),
      anchor_sum_m_(params.anchors.size(), Eigen::Vector3d::Zero()),
      anchor_frames_(params.anchors.size(), 0) {
    frame_.kind = params.kind;
    if (params.kind == WorldFrameKind::kSensor) {
        frame_.fixed = true;
        frame_.note = "the root sensor at its first frame";
    } else if (params.kind == WorldFrameKind::kGeo && params.T_world_root) {
        frame_ = geo_frame_from(*params.T_world_root, params.offset_step_m);
    }
}

bool WorldFrameTracker::update(const FrameOutput& out) {
    if (frame_.fixed) return false;
    const std::size_t root = params_.root_sensor;
    if (root_first_frame_ < 0 && root < out.health.size() && out.health[root].pose_valid) {
        root_first_frame_ = out.frame_index;
    }
    if (params_.kind == WorldFrameKind::kRoad) return update_road(out);
    if (params_.kind == WorldFrameKind::kGeo) return update_geo(out);
    return false;
}

bool WorldFrameTracker::update_road(const FrameOutput& out) {
    const auto& applied = out.applied_registration;
    if (!road_planes_ && applied && applied->job && applied->job->done() &&
        !applied->job->result().sensors.empty()) {  // empty: cancelled or failed, wait
        road_planes_.emplace(road_planes_of(applied->job->result(), applied->T_root0_root),
                             applied->T_root0_root);
    }
    if (root_first_frame_ < 0 || out.frame_index < root_first_frame_ + params_.settle_frames) {
        return false;
    }
    if (!road_planes_ && num_sensors_ == 1) {
        road_planes_.emplace(std::vector<RoadPlaneObservation>{root_plane_of(out.cloud)},
                             Eigen::Isometry3d::Identity());
    }
    if (!road_planes_) return false;
    WorldFrame f = road_frame_or_root_frame(road_planes_->first, road_planes_->second, &out.cloud,
                                            params_.road);
    road_planes_.reset();
    f.frame_index = out.frame_index;
    frame_ = std::move(f);
    return true;
}

bool WorldFrameTracker::update_geo(const FrameOutput& out) {
    const std::size_t root = params_.root_sensor;
    registration_applied_ =
        registration_applied_ || out.applied_registration.has_value() ||
        (num_sensors_ == 1 && root < out.health.size() && out.health[root].pose_valid);
    if (!registration_applied_ || out.initial_registration_pending) return false;
    if (!out.registered) return false;  // the positions averaged are measured ones
    for (std::size_t i = 0; i < params_.anchors.size(); ++i) {
        const std::size_t s = params_.anchors[i].sensor;
        if (s >= out.health.size() || !out.health[s].pose_valid) continue;
        anchor_sum_m_[i] += out.T_root_sensor[s].translation();
        ++anchor_frames_[i];
    }
    ++geo_frames_;
    if (geo_frames_ < std::max(1, params_.geo_average_frames)) return false;
    std::vector<Eigen::Vector3d> in_root, in_world;
    for (std::size_t i = 0; i < params_.anchors.size(); ++i) {
        // Tracked in fewer than half the frames: its mean is biased by its sway.
        if (anchor_frames_[i] == 0 || 2 * anchor_frames_[i] < geo_frames_) continue;
        in_root.push_back(anchor_sum_m_[i] / anchor_frames_[i]);
        in_world.push_back(params_.anchors[i].position_m);
    }
    if (in_root.size() < 3) return false;  // keep averaging until 3 anchors are tracked
    WorldFrame f = fit_geo_frame(in_root, in_world, params_.offset_step_m);
    if (!f.fixed) return false;
    f.num_frames = static_cast<std::size_t>(geo_frames_);
    f.note += " averaged over " + std::to_string(geo_frames_) + " frames";
    // anchor_residuals_m in the order of params_.anchors when every anchor was used.
    f.frame_index = out.frame_index;
    frame_ = std::move(f);
    return true;
}

void WorldFrameTracker::apply(FrameOutput* out) const {
    if (!frame_.fixed || frame_.T_fused_root.matrix() == Eigen::Matrix4d::Identity()) return;
    for (std::size_t s = 0; s < out->T_root_sensor.size(); ++s) {
        // A sensor without a pose keeps the identity: never an invented pose.
        if (s < out->health.size() && out->health[s].pose_valid) {
            out->T_root_sensor[s] = frame_.T_fused_root * out->T_root_sensor[s];
        }
    }
    const Eigen::Isometry3f T = frame_.T_fused_root.cast<float>();
    for (auto& p : out->cloud.points) p = T * p;
}

}  // namespace lidarfuse::core
