#pragma once
// Free-space (visibility) consistency of a candidate transform between two sensors (ours:
// not in the paper; it refuses candidates the paper's p2p error would accept).
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
// The target's free space is a FreeSpaceMap: its first returns binned on an azimuth x
// elevation grid in the target's frame (the sensor at the origin), each bin keeping the
// smallest range seen and how obliquely that return's surface was hit. Built once per
// sensor from its full pre-processed cloud: free space is what the sensor's own rays
// measured, and a downsampled proxy (voxel centroids) would report ranges no ray measured.
// A source point is "tested" when its bin holds a return, and a "violation" when its range
// is below that smallest range by more than
//     margin_m + margin_share * range + first_return * bin_rad * tan(incidence)
// The last term is how far the first surface's range can change across one bin when the
// ray meets it at `incidence` from its normal: near-zero for a facade seen head-on, metres
// for a road seen at a grazing angle from a low mount or between widely spaced beams
// (measured on the real vehicle rigs: bench/BENCHMARK.md). Both directions (source into
// target and target into source) are checked by the caller or by `check_both`.
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
    // A point is a violation when range < bin's smallest range - (margin_m + margin_share *
    // range + the incidence term of the file comment).
    double margin_m = 1.0;
    double margin_share = 0.02;
    // The incidence term's angle is capped here (deg): at 90 deg the range across a bin is
    // unbounded, and such a return bounds nothing.
    double max_incidence_deg = 80.0;
    // Points nearer than this to the checking sensor are not tested (m).
    double min_range_m = 1.0;
};

// One sensor's observed free space: per ray bin the smallest range and the tangent of the
// incidence angle of that return (0 where no normal was given).
class FreeSpaceMap {
public:
    FreeSpaceMap() = default;
    // `points` in the sensor frame; `normals` unit (any sign), same size, or empty.
    FreeSpaceMap(const std::vector<Eigen::Vector3d>& points,
                 const std::vector<Eigen::Vector3d>& normals, const FreeSpaceParams& params = {});

    bool empty() const { return min_range_m_.empty(); }
    // The bin of a point in this sensor's frame, -1 at the origin or when not finite.
    long bin(const Eigen::Vector3d& p, double* range) const;
    // Smallest range of the bin (infinity when the sensor saw nothing there) and the range
    // the first surface may vary by across the bin (the incidence term).
    double first_return_m(long bin) const { return min_range_m_[static_cast<std::size_t>(bin)]; }
    double range_slack_m(long bin) const { return range_slack_m_[static_cast<std::size_t>(bin)]; }
    const FreeSpaceParams& params() const { return params_; }

private:
    FreeSpaceParams params_;
    int num_azimuth_ = 0;
    int num_elevation_ = 0;
    std::vector<float> min_range_m_;
    std::vector<float> range_slack_m_;
};

struct FreeSpaceResult {
    std::size_t num_tested = 0;      // points whose ray bin holds a return of the other sensor
    std::size_t num_violations = 0;  // of those, points in the other sensor's free space
    double violation_share = 0.0;    // num_violations / num_tested (0 when none tested)
};

// Source points (source frame) checked against the target's free space (target frame).
// The map's params apply.
FreeSpaceResult free_space_violations(const std::vector<Eigen::Vector3d>& source_points,
                                      const FreeSpaceMap& target,
                                      const Eigen::Isometry3d& T_target_source);

// Both directions combined: the larger of the two violation shares, with the counts of
// that direction.
FreeSpaceResult free_space_violations_both(const std::vector<Eigen::Vector3d>& source_points,
                                           const FreeSpaceMap& source,
                                           const std::vector<Eigen::Vector3d>& target_points,
                                           const FreeSpaceMap& target,
                                           const Eigen::Isometry3d& T_target_source);

// The same on point clouds alone: each one's map is built from its points, without the
// incidence term.
FreeSpaceResult free_space_violations(const std::vector<Eigen::Vector3d>& source_points,
                                      const std::vector<Eigen::Vector3d>& target_points,
                                      const Eigen::Isometry3d& T_target_source,
                                      const FreeSpaceParams& params = {});
FreeSpaceResult free_space_violations_both(const std::vector<Eigen::Vector3d>& source_points,
                                           const std::vector<Eigen::Vector3d>& target_points,
                                           const Eigen::Isometry3d& T_target_source,
                                           const FreeSpaceParams& params = {});

}  // namespace lidarfuse::core
