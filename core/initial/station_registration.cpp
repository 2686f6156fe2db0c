#include "core/initial/station_registration.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/common/se3.hpp"
#include "core/common/stopwatch.hpp"
#include "core/preprocess/normals.hpp"
#include "core/preprocess/voxel_grid.hpp"
#include "core/registration/gicp.hpp"

namespace lidarfuse::core {

namespace {

// One pair's outcome: source placed in target's road frame, or why not.
struct StationEdge {
    int source = -1, target = -1;
    bool placed = false;
    bool ambiguous = false;  // refused for a rival placement
    double rival_share = 1.0;
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
};

GicpCloud gicp_cloud(const PointCloud& cloud, const StationRegistrationParams& p, int threads) {
    VoxelGridParams voxels;
    voxels.voxel_size_m = p.gicp_voxel_m;
    NormalParams covariances;
    covariances.k_neighbors = p.covariance_neighbors;
    covariances.compute_normals = false;
    covariances.orient_towards_viewpoint = false;
    return GicpCloud(voxel_downsample(cloud.points, voxels), covariances, 10, threads);
}

// The grid's placement, refined by G-ICP; refused when G-ICP moves it far (it slid into
// another basin) or keeps few inliers.
StationEdge place(const PointCloud& target, const PointCloud& source, const GicpCloud& target_gicp,
                  const GicpCloud& source_gicp, const InitialRegistrationParams& params,
                  int threads) {
    const StationRegistrationParams& p = params.stations;
    StationEdge edge;
    const RoadGridPlacement grid =
        search_road_grid(target.points, source.points, p.search, threads);
    edge.rival_share = grid.score > 0 ? grid.rival_score / grid.score : 1.0;
    edge.ambiguous = !grid.found && grid.rival_score > 0;
    if (!grid.found) return edge;
    Eigen::Isometry3d T = grid.T_target_source;
    GicpResult result;
    for (const double bound : p.gicp_max_correspondence_m) {
        GicpParams g = params.pair.gicp;
        g.max_correspondence_distance_m = bound;
        result = align_gicp(target_gicp, source_gicp, T, g, threads);
        T = result.T_target_source;
    }
    edge.placed = result.num_inliers >= p.min_inliers &&
                  translation_error_m(T, grid.T_target_source) <= p.max_refinement_move_m &&
                  rotation_error_deg(T, grid.T_target_source) <= p.max_refinement_move_deg;
    edge.T_target_source = T;
    return edge;
}

// A station's road plane is z = 0 of its own frame, with its origin on it.
GroundPlane road_plane(const PointCloud& cloud, const RoadGridSearchParams& search) {
    GroundPlane g;
    for (const auto& q : cloud.points) g.num_inliers += std::abs(q.z()) <= search.road_tolerance_m;
    g.found = g.num_inliers > 0;
    return g;
}

// Every pair i > j, in order (1,0), (2,0), (2,1), ...
std::vector<StationEdge> place_pairs(const std::vector<PointCloud>& clouds,
                                     const InitialRegistrationParams& params, int threads) {
    std::vector<GicpCloud> gicp;
    for (const auto& c : clouds) gicp.push_back(gicp_cloud(c, params.stations, threads));
    std::vector<StationEdge> edges;
    for (std::size_t i = 1; i < clouds.size(); ++i) {
        for (std::size_t j = 0; j < i; ++j) {
            if (params.cancel_requested()) return edges;
            StationEdge e;
            if (!clouds[i].points.empty() && !clouds[j].points.empty())
                e = place(clouds[j], clouds[i], gicp[j], gicp[i], params, threads);
            e.source = static_cast<int>(i);
            e.target = static_cast<int>(j);
            edges.push_back(e);
        }
    }
    return edges;
}

// From the root, each station through its least ambiguous placed pair with a placed one.
void join_from_root(const std::vector<StationEdge>& edges, InitialRegistrationResult* result) {
    auto& sensors = result->sensors;
    sensors[0].registered = true;
    sensors[0].status = SensorRegistrationStatus::kRegistered;
    while (true) {
        const StationEdge* best = nullptr;
        for (const auto& e : edges) {
            if (!e.placed || sensors[e.source].registered == sensors[e.target].registered) continue;
            if (!best || e.rival_share < best->rival_share) best = &e;
        }
        if (!best) return;
        const bool forward = sensors[best->target].registered;  // source joins
        const int from = forward ? best->target : best->source;
        const int joins = forward ? best->source : best->target;
        sensors[joins].T_root_sensor =
            sensors[from].T_root_sensor *
            (forward ? best->T_target_source : best->T_target_source.inverse());
        sensors[joins].registered = true;
        sensors[joins].status = SensorRegistrationStatus::kRegistered;
    }
}

}  // namespace

InitialRegistrationResult register_stations(const std::vector<PointCloud>& clouds,
                                            const InitialRegistrationParams& params,
                                            int num_threads) {
    const Stopwatch whole;
    InitialRegistrationResult result;
    const int threads = std::max(1, num_threads);
    result.sensors.resize(clouds.size());
    if (clouds.empty()) return result;
    for (std::size_t i = 0; i < clouds.size(); ++i) {
        result.sensors[i].num_input_points = clouds[i].points.size();
        result.sensors[i].ground = road_plane(clouds[i], params.stations.search);
    }
    const Stopwatch pairs;
    const std::vector<StationEdge> edges = place_pairs(clouds, params, threads);
    result.timings.pairs_s = pairs.seconds();
    if (params.cancel_requested()) {
        for (auto& s : result.sensors) s.status = SensorRegistrationStatus::kCancelled;
    } else if (!clouds[0].points.empty()) {
        join_from_root(edges, &result);
    }
    for (std::size_t i = 0; i < clouds.size() && !params.cancel_requested(); ++i) {
        SensorRegistration& s = result.sensors[i];
        if (s.registered) continue;
        const bool ambiguous = std::any_of(edges.begin(), edges.end(), [&](const StationEdge& e) {
            return e.ambiguous &&
                   (e.source == static_cast<int>(i) || e.target == static_cast<int>(i));
        });
        s.status = clouds[i].points.empty() ? SensorRegistrationStatus::kEmptyCloud
                   : ambiguous              ? SensorRegistrationStatus::kAmbiguous
                               : SensorRegistrationStatus::kNoConsistentCorrespondences;
    }
    result.timings.total_s = whole.seconds();
    return result;
}

}  // namespace lidarfuse::core
