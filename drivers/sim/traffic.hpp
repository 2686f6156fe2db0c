#pragma once
// Road users: cars, trucks, motorcycles, bicycles and pedestrians moving along the scene's
// tracks at constant speed, appearing at a track's start and leaving at its end. Seeded
// spawn times per track (exponential headways with a minimum gap); everything on one track
// moves at the track's speed, so no agent overtakes or touches another on the same track.
// At a signalised junction an agent only exists if its passage through the junction box
// falls inside its group's green phase (a fixed-time plan, no queues).
// Positions are analytic in time, so any instant can be evaluated from any thread.

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "drivers/sim/mesh.hpp"
#include "drivers/sim/scene.hpp"

namespace lidarfuse::sim {

enum class AgentClass : std::uint8_t { kCar, kTruck, kMotorcycle, kBicycle, kPedestrian };
const char* to_string(AgentClass c);

struct Agent {
    AgentClass cls = AgentClass::kCar;
    int track = 0;
    double enter_time_s = 0;  // time at which the agent's centre is at arc length 0
    double length_m = 4.5;
    Material paint = Material::kCarPaint;
};

// One box of an agent's body at two instants (for motion-blurred ray casting).
struct MovingBox {
    Eigen::Isometry3d T_world_box_t0 = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_world_box_t1 = Eigen::Isometry3d::Identity();
    Eigen::Vector3d half_m = Eigen::Vector3d::Zero();
    Material material = Material::kCarPaint;
};

struct TrafficParams {
    double duration_s = 10.0;
    std::uint64_t seed = 1;
    double density = 1.0;  // multiplies spawn rates
};

class Traffic {
public:
    Traffic(const Scene& scene, const TrafficParams& params);

    const std::vector<Agent>& agents() const { return agents_; }
    // Every box of every agent that is on its track at some time in [t0_s, t1_s], with its
    // pose at t0_s and at t1_s (cleared first).
    void moving_boxes(double t0_s, double t1_s, std::vector<MovingBox>* out) const;
    // Agent pose (x forward, z up, origin on the surface under its centre) at time t_s.
    Eigen::Isometry3d agent_pose(const Agent& agent, double t_s) const;

private:
    const Scene* scene_;
    std::vector<Agent> agents_;
};

}  // namespace lidarfuse::sim
