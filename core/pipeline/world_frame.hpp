#pragma once
// The world frame (station.yaml `world:`, ours: the paper stops at the root frame): which
// frame the fused cloud and the poses are expressed in. FusionEngine works in the root
// frame (the root sensor at its first frame, tilted with its pole); a WorldFrame maps it to
// the frame people use:
//
//   road    z along the road plane's normal, origin on the road below the root sensor, x
//           the root's x axis projected onto the road. The plane: every registered
//           sensor's road plane from the initial registration (ground_plane.hpp, mapped
//           into the root frame with the registered poses, weighted by their inliers),
//           refined on the static points of the fused cloud of the frame that applied it
//           (a shrinking band around the plane: sidewalks 15 cm up and cars stay out).
//   geo     geo-referenced: T_world_root fitted by SVD (Kabsch, no scale, the paper's
//           T_coord) from the sensors' positions in the root frame to their known positions
//           in a projected system (UTM or a local ENU), or given. The fused frame is that
//           world frame shifted by a whole-metre offset (T_world_fused, a pure translation,
//           published as a static transform) so float32 clouds keep millimetres.
//   sensor  the root frame itself (T_fused_root = identity).
//
// Poses out: T_fused_sensor = T_fused_root * T_root_sensor. Units: metres. Deterministic,
// single-threaded; no allocation per frame once fixed (apply() works in place).

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/initial/ground_plane.hpp"
#include "core/initial/initial_registration.hpp"
#include "core/pipeline/fusion_types.hpp"

namespace lidarfuse::core {

enum class WorldFrameKind { kRoad, kGeo, kSensor };
const char* to_string(WorldFrameKind kind);
// The kind named by to_string(); nullopt for any other name.
std::optional<WorldFrameKind> world_frame_kind_from(const std::string& name);

// A sensor's known position in the world (geo) frame, e.g. surveyed UTM easting, northing
// and height of its optical centre (m).
struct GeoAnchor {
    std::size_t sensor = 0;  // index in the configuration
    Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
};

struct RoadFrameParams {
    // Refinement bands around the plane (m), applied in turn to the fused cloud's static
    // points; each round refits the plane by PCA to the points inside the band.
    std::vector<double> bands_m = {0.10, 0.06, 0.04};
    // Fewer road points than this in a band: keep the plane from the sensors' planes.
    std::size_t min_points = 200;
};

struct WorldFrameParams {
    WorldFrameKind kind = WorldFrameKind::kRoad;
    std::size_t root_sensor = 0;
    RoadFrameParams road{};
    // geo: at least 3 anchors (not in a line), or T_world_root given.
    std::vector<GeoAnchor> anchors;
    std::optional<Eigen::Isometry3d> T_world_root;
    // geo: the offset is the fit's translation rounded to a multiple of this (m).
    double offset_step_m = 1.0;
    // geo with anchors: the known positions are surveyed rest positions, so they are fitted
    // to each anchor's position averaged over this many frames (those with no initial
    // registration pending, from the first registration applied on), not to one frame's:
    // a swaying pole's sensor is up to its sway amplitude off its rest position at any one
    // frame. The average has to span at least one whole sway period to cancel: the paper's
    // pole (an inverted pendulum, 6 m) swings with 2 pi sqrt(6 m / 9.81 m/s^2) = 4.9 s, so
    // 100 frames (5 s at 20 Hz, 10 s at 10 Hz; bench/BENCHMARK.md). An anchor counts when it
    // had a pose in at least half of the frames; 1: one frame's poses. Registered frames
    // only (FrameOutput::registered): a predicted pose adds no measurement.
    int geo_average_frames = 100;
    // road: the plane is estimated on the fused cloud of a frame at least this many frames
    // after the root's first: with deskew, FusionEngine re-anchors the root's reference
    // FusionParams::deskew_reference_after_frames after it, which tilts the root frame by the
    // root's motion over half a sweep (bench/BENCHMARK.md), and the road must be found in the
    // frame the poses are in from then on. Set it to deskew_reference_after_frames + 1 with
    // deskew, 0 without (world_frame_settle_frames()).
    int settle_frames = 0;
};

inline int world_frame_settle_frames(const FusionParams& fusion) {
    return fusion.deskew ? fusion.deskew_reference_after_frames + 1 : 0;
}

struct WorldFrame {
    WorldFrameKind kind = WorldFrameKind::kSensor;
    bool fixed = false;  // false: not known yet (road: before the initial registration)
    Eigen::Isometry3d T_fused_root = Eigen::Isometry3d::Identity();
    // geo: the world -> fused static transform (a translation: the large offset); identity
    // for road and sensor, whose fused frame is the world frame.
    Eigen::Isometry3d T_world_fused = Eigen::Isometry3d::Identity();
    // road: rms distance of the road points to the plane; geo (fit): rms and largest
    // distance |T_world_root * p_root_i - p_world_i| over the anchors, and each anchor's.
    double residual_rms_m = 0.0;
    double residual_max_m = 0.0;
    std::vector<double> anchor_residuals_m;  // geo fit: per anchor, in anchor order
    std::size_t num_sensors = 0;             // road: sensor planes used; geo: anchors fitted
    std::size_t num_frames = 0;              // geo fit: frames the anchors were averaged over
    std::size_t num_road_points = 0;         // road: points of the last refinement band
    double root_height_m = 0.0;              // road: the root sensor above the road plane
    std::int64_t frame_index = -1;           // the frame it was fixed at (-1: from the config)
    std::string note;                        // how it was fixed, or why it fell back
};

// The road frame from the registered sensors' road planes (sensor frames) and poses (root
// frame), refined on `cloud` (root frame; may be null). `root_pose` is the root's pose in
// the root frame at the registration's frame. fixed = false when no plane was found.
struct RoadPlaneObservation {
    Eigen::Isometry3d T_root_sensor = Eigen::Isometry3d::Identity();
    GroundPlane ground;
};
WorldFrame estimate_road_frame(const std::vector<RoadPlaneObservation>& sensors,
                               const Eigen::Isometry3d& root_pose, const FusedCloud* cloud,
                               const RoadFrameParams& params = {});
// The road planes of the root (result.sensors[0]) and of every sensor the registration
// placed, with their poses mapped by T_root0_root (the root's pose at the registration's
// frame; identity for a registration on its own).
std::vector<RoadPlaneObservation> road_planes_of(const InitialRegistrationResult& result,
                                                 const Eigen::Isometry3d& T_root0_root);
// estimate_road_frame, or, when no sensor saw a road, the root frame itself (fixed, as
// world.frame: sensor), with the reason in its note.
WorldFrame road_frame_or_root_frame(const std::vector<RoadPlaneObservation>& sensors,
                                    const Eigen::Isometry3d& root_pose, const FusedCloud* cloud,
                                    const RoadFrameParams& params = {});

// geo from positions: T_world_root by Kabsch from positions_root[i] -> positions_world[i].
// fixed = false (and a note) with fewer than 3 positions or positions in a line.
WorldFrame fit_geo_frame(const std::vector<Eigen::Vector3d>& positions_root,
                         const std::vector<Eigen::Vector3d>& positions_world,
                         double offset_step_m = 1.0);
// geo from a given T_world_root.
WorldFrame geo_frame_from(const Eigen::Isometry3d& T_world_root, double offset_step_m = 1.0);

// Follows FusionEngine's output frame by frame and fixes the world frame once:
//   sensor, geo with T_world_root: at construction;
//   road: from the first initial registration applied (FrameOutput::applied_registration;
//     the root is never registered again within an engine's life, so it is never
//     re-estimated): its sensors' planes, refined on the fused cloud of that frame or, when
//     the root started fewer than settle_frames before, of the first frame that many after
//     it; no road plane found at all: the sensor frame, with a note; a station of one
//     sensor (no registration to apply): the root's own plane, from its cloud, at once;
//   geo with anchors: once geo_average_frames frames with no initial registration pending
//     (from the first registration applied on) have been averaged and at least 3 anchors
//     had a pose in at least half of them; the fit uses each anchor's mean position.
// Not thread safe: one thread calls update() and apply().
class WorldFrameTracker {
public:
    WorldFrameTracker(const WorldFrameParams& params, std::size_t num_sensors);

    // True when the frame became fixed in this call.
    bool update(const FrameOutput& out);
    const WorldFrame& frame() const { return frame_; }
    bool fixed() const { return frame_.fixed; }

    // Re-expresses `out` in the fused frame: every T_root_sensor becomes T_fused_sensor and
    // the cloud's points move with it. Identity (nothing done) until fixed, and for sensor.
    void apply(FrameOutput* out) const;

private:
    // The steps of update() for each kind that is fixed from the frames; true when fixed.
    bool update_road(const FrameOutput& out);
    bool update_geo(const FrameOutput& out);

    WorldFrameParams params_;
    std::size_t num_sensors_;
    bool registration_applied_ = false;
    std::int64_t root_first_frame_ = -1;  // the first frame the root had a pose
    // geo with anchors: per anchor (params_.anchors order), the sum of its positions in the
    // root frame and the frames it had a pose in; the frames averaged so far.
    std::vector<Eigen::Vector3d> anchor_sum_m_;
    std::vector<int> anchor_frames_;
    int geo_frames_ = 0;
    // road: the applied registration's planes (root frame) and root pose, until settled.
    std::optional<std::pair<std::vector<RoadPlaneObservation>, Eigen::Isometry3d>> road_planes_;
    WorldFrame frame_;
};

}  // namespace lidarfuse::core
