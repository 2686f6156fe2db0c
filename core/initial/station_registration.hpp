#pragma once
// Ours (issue 20): the initial registration of a road segment, whose "sensors" are stations'
// fused clouds, each in its own road frame (z along the road's normal, the road at z = 0).
// The paper's feature registration was made for one station's sensors, which overlap
// heavily and confirm each other; two stations 80 m apart share a sixth of their view and
// the road looks alike from both ends (bench/BENCHMARK.md, "The mirrored station"). Here:
//
//   for every pair i > j:  road_grid_search.hpp places i against j over every yaw and
//                          horizontal shift, or refuses (too little in common, or a rival
//                          placement nearly as good); G-ICP (coarse to fine) then adds z,
//                          roll and pitch and the last centimetres, and must stay within
//                          max_refinement_move of the grid's placement;
//   from the root:         each station joins through its least ambiguous placed pair with
//                          a station already placed (a spanning tree; stations along a road
//                          overlap their neighbours only, so there are no cycles to check).
//
// Output as register_initial's: T_root_sensor per station (root = station 0), the road
// plane of each (z = 0 of its frame) as its ground. A station no pair places gets
// kAmbiguous (some pair found a rival) or kNoConsistentCorrespondences, never a guess.

#include <vector>

#include "core/common/point_cloud.hpp"
#include "core/initial/initial_registration.hpp"

namespace lidarfuse::core {

// The stations' clouds (road frames), in sensor order; params.stations and params.pair's
// G-ICP settings apply. Cancellation as register_initial's.
InitialRegistrationResult register_stations(const std::vector<PointCloud>& clouds,
                                            const InitialRegistrationParams& params,
                                            int num_threads = 1);

}  // namespace lidarfuse::core
