#pragma once
// A 2-D polyline parametrised by arc length: road centrelines and the lanes and sidewalk
// tracks that traffic follows. World frame, metres; headings in radians from +x.

#include <Eigen/Core>
#include <vector>

namespace lidarfuse::sim {

class Path {
public:
    Path() = default;
    explicit Path(std::vector<Eigen::Vector2d> points);

    double length() const { return s_.empty() ? 0.0 : s_.back(); }
    Eigen::Vector2d position(double s) const;
    Eigen::Vector2d tangent(double s) const;  // unit
    Eigen::Vector2d left(double s) const {    // unit normal pointing left of travel
        const Eigen::Vector2d t = tangent(s);
        return {-t.y(), t.x()};
    }
    double heading(double s) const;
    // The same track shifted sideways (positive = left), resampled every `step_m`.
    Path offset(double lateral_m, double step_m = 1.0) const;
    Path reversed() const;
    const std::vector<Eigen::Vector2d>& points() const { return points_; }

private:
    std::size_t segment(double s) const;
    std::vector<Eigen::Vector2d> points_;
    std::vector<double> s_;  // cumulative arc length at each point
};

// Straight line from a to b; circular arc by centre, radius and angle span (radians,
// counter-clockwise when end > start), sampled every `step_m`.
Path straight_path(const Eigen::Vector2d& a, const Eigen::Vector2d& b);
std::vector<Eigen::Vector2d> arc_points(const Eigen::Vector2d& centre, double radius_m,
                                        double start_rad, double end_rad, double step_m);

}  // namespace lidarfuse::sim
