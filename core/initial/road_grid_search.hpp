#pragma once
// Ours (issue 20): the placement of one station's fused cloud against another's, from
// nothing, when each is in its own road frame (world_frame.hpp: z along the road's normal,
// the road at z = 0). Two such frames differ by a yaw and a horizontal shift, so the search
// is exhaustive over both, on bird's-eye grids of what each station saw:
//   occupied: a cell with points in a band above the road (poles, walls, trunks, vehicles);
//   free:     a cell where only road was seen: the rays reached the road there, so nothing
//             stood on it.
// A placement scores the cells both see occupied, less `free_weight` for every cell one
// sees occupied where the other saw free road. The free cells decide: a station 80 m down
// a straight road shares a little of the other's street, and a placement that turns it
// round onto the other's own street overlaps far more of it (the mirrored look-alike the
// features' registration accepted: bench/BENCHMARK.md, "The mirrored station"), but it puts
// that structure on road the other saw empty.
//
// Every yaw step scores every shift at once, as one cross-correlation by FFT (Eigen's FFT
// module); the best peaks of all yaws are kept, and the best is refined on a finer grid in
// yaw and shift around it. Refused (found = false, `why` set) when the best scores little,
// or when a rival (a peak farther than the rival separation) scores more than
// max_rival_share of it: a road that repeats along its length, or too little in common.
//
// Frames: both clouds in their own road frames (m). T_target_source maps the source's
// road frame into the target's: a rotation about z and a shift in x, y (z, roll and pitch
// are left to the caller's G-ICP). Deterministic; the yaw steps run on `num_threads`
// OpenMP threads.

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace lidarfuse::core {

struct RoadGridSearchParams {
    double coarse_cell_m = 2.0;  // grid of the exhaustive search
    double coarse_yaw_step_deg = 2.0;
    double fine_cell_m = 0.5;  // grid of the refinement around the best
    double fine_yaw_step_deg = 0.25;
    double half_extent_m = 128.0;  // each grid spans +-this around its road frame's origin
    // Occupied: points this high above the road (m); above it, canopies and bridges that
    // the road beneath is seen through.
    double min_height_m = 0.3;
    double max_height_m = 3.0;
    double road_tolerance_m = 0.15;  // free: points this close to the road, nothing above
    double free_weight = 1.0;
    // A rival is a peak at least this far from the best, in shift or in yaw.
    double rival_separation_m = 6.0;
    double rival_separation_deg = 10.0;
    double max_rival_share = 0.5;
    double min_score_cells = 20.0;  // on the coarse grid
};

struct RoadGridPlacement {
    bool found = false;
    std::string why;  // when not found
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    double yaw_deg = 0.0;
    double score = 0.0;        // coarse cells (occupied in both, less the weighted conflicts)
    double rival_score = 0.0;  // the best rival's, on the same grid
    double rival_yaw_deg = 0.0;
    Eigen::Vector2d rival_shift_m = Eigen::Vector2d::Zero();
};

RoadGridPlacement search_road_grid(const std::vector<Eigen::Vector3d>& target,
                                   const std::vector<Eigen::Vector3d>& source,
                                   const RoadGridSearchParams& params = {}, int num_threads = 1);

}  // namespace lidarfuse::core
