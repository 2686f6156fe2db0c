#pragma once
// Free-space (visibility) consistency of a candidate transform between two sensors.
//
// A sensor's measured range along a ray says the space in front of the first return is
// empty. If T_target_source is right, source points mapped into the target's frame lie on
// or behind the target's first returns along the same rays (or where the target saw
// nothing); points clearly in front of the target's first return would have blocked the
// target's ray and contradict T. A wrong transform that overlays a look-alike structure
// (e.g. the four similar arms of an intersection) puts much of the source cloud into the
// target's observed free space, while the right one violates it only through noise,
// moving objects and the coarse ray binning.
//
// The target's first returns are binned on an azimuth x elevation grid in the target's
// frame (the sensor at the origin); each bin keeps the smallest range seen. A source point
// is "tested" when its bin holds a return, and a "violation" when its range is below that
// smallest range by more than `margin_m + margin_share * range`. Both directions (source
// into target and target into source) are checked by the caller or by `check_both`.
//
// Frames: clouds in their own sensor frames. Units: metres, degrees. Deterministic,
// single-threaded, O(N).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

namespace lidarfuse::core {

struct FreeSpaceParams {
    // Ray bins (deg). Coarser than the beam spacing on purpose: the smallest range of a
    // bin is a conservative first-surface estimate, so edges do not count as violations.
    double azimuth_bin_deg = 1.0;
    double elevation_bin_deg = 1.0;
    // A point is a violation when range < bin's smallest range - (margin_m + margin_share * range).
    double margin_m = 1.0;
    double margin_share = 0.02;
    // Points nearer than this to the checking sensor are not tested (m).
    double min_range_m = 1.0;
};

struct FreeSpaceResult {
    std::size_t num_tested = 0;      // points whose ray bin holds a return of the other sensor
    std::size_t num_violations = 0;  // of those, points in the other sensor's free space
    double violation_share = 0.0;    // num_violations / num_tested (0 when none tested)
};

// Source points (source frame) checked against the target's returns (target frame).
FreeSpaceResult free_space_violations(const std::vector<Eigen::Vector3d>& source_points,
                                      const std::vector<Eigen::Vector3d>& target_points,
                                      const Eigen::Isometry3d& T_target_source,
                                      const FreeSpaceParams& params = {});

// Both directions combined: the larger of the two violation shares, with the counts of
// that direction.
FreeSpaceResult free_space_violations_both(const std::vector<Eigen::Vector3d>& source_points,
                                           const std::vector<Eigen::Vector3d>& target_points,
                                           const Eigen::Isometry3d& T_target_source,
                                           const FreeSpaceParams& params = {});

}  // namespace lidarfuse::core
