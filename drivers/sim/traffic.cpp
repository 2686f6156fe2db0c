#include "drivers/sim/traffic.hpp"

#include <algorithm>
#include <cmath>

#include "drivers/sim/rng.hpp"

namespace lidarfuse::sim {

namespace {

struct Part {
    Eigen::Vector3d centre;  // in the agent frame
    Eigen::Vector3d half;
    bool painted;  // paint colour, else glass/cloth by class
};

// Body parts of a class for a given length (metres).
std::vector<Part> parts(AgentClass c, double L) {
    switch (c) {
        case AgentClass::kCar:
            return {{{0, 0, 0.65}, {L / 2, 0.9, 0.35}, true},
                    {{-0.1 * L, 0, 1.25}, {0.28 * L, 0.8, 0.25}, false}};
        case AgentClass::kTruck:
            return {{{L / 2 - 1.1, 0, 1.7}, {1.1, 1.25, 1.4}, true},
                    {{-1.15, 0, 2.15}, {L / 2 - 1.15, 1.27, 1.65}, false}};
        case AgentClass::kMotorcycle:
            return {{{0, 0, 0.55}, {L / 2, 0.35, 0.35}, true},
                    {{-0.1, 0, 1.25}, {0.3, 0.3, 0.4}, false}};
        case AgentClass::kBicycle:
            return {{{0, 0, 0.5}, {L / 2, 0.08, 0.35}, true},
                    {{-0.1, 0, 1.3}, {0.25, 0.22, 0.45}, false}};
        case AgentClass::kPedestrian:
            return {{{0, 0, 0.45}, {0.15, 0.18, 0.45}, false},
                    {{0, 0, 1.22}, {0.14, 0.24, 0.32}, true},
                    {{0, 0, 1.66}, {0.1, 0.09, 0.12}, false}};
    }
    return {};
}

Material unpainted(AgentClass c) {
    switch (c) {
        case AgentClass::kCar:
            return Material::kGlass;
        case AgentClass::kTruck:
            return Material::kFacade;  // trailer box
        default:
            return Material::kCloth;
    }
}

AgentClass draw_class(const Track& t, CounterRng& rng) {
    const double u = rng.uniform();
    switch (t.kind) {
        case TrackKind::kSidewalk:
            return AgentClass::kPedestrian;
        case TrackKind::kCyclePath:
            return AgentClass::kBicycle;
        case TrackKind::kRoadLane:
            break;
    }
    if (t.lane_index >= 2 && u < 0.3) return AgentClass::kTruck;
    if (t.lane_index == 0 && u < 0.15) return AgentClass::kMotorcycle;
    return AgentClass::kCar;
}

double draw_length(AgentClass c, CounterRng& rng) {
    switch (c) {
        case AgentClass::kCar:
            return rng.uniform(4.0, 5.0);
        case AgentClass::kTruck:
            return rng.uniform(9.0, 16.5);
        case AgentClass::kMotorcycle:
            return rng.uniform(2.0, 2.3);
        case AgentClass::kBicycle:
            return rng.uniform(1.6, 1.9);
        case AgentClass::kPedestrian:
            return 0.4;
    }
    return 4.5;
}

}  // namespace

const char* to_string(AgentClass c) {
    switch (c) {
        case AgentClass::kCar:
            return "car";
        case AgentClass::kTruck:
            return "truck";
        case AgentClass::kMotorcycle:
            return "motorcycle";
        case AgentClass::kBicycle:
            return "bicycle";
        case AgentClass::kPedestrian:
            return "pedestrian";
    }
    return "?";
}

Traffic::Traffic(const Scene& scene, const TrafficParams& params) : scene_(&scene) {
    const Material paints[] = {Material::kCarPaint, Material::kMetal, Material::kFacade,
                               Material::kCloth};
    for (std::size_t ti = 0; ti < scene.tracks.size(); ++ti) {
        const Track& track = scene.tracks[ti];
        CounterRng rng(params.seed, 0x747261666669ULL /* "traffi" */, ti);
        const double transit_s = track.path.length() / track.speed_mps;
        const double mean = track.mean_headway_s / std::max(params.density, 1e-6);
        double t = -transit_s + rng.uniform(0.0, mean);
        double prev_length = 0.0;
        while (t < params.duration_s) {
            Agent a;
            a.cls = draw_class(track, rng);
            a.track = static_cast<int>(ti);
            a.length_m = draw_length(a.cls, rng);
            a.paint = paints[static_cast<int>(rng.uniform() * 4) % 4];
            // Enforce a gap of 3 m (pedestrians 1 m) to the agent ahead.
            const double gap_m =
                (a.length_m + prev_length) / 2 + (a.cls == AgentClass::kPedestrian ? 1.0 : 3.0);
            const double min_dt = gap_m / track.speed_mps;
            a.enter_time_s = t;
            bool allowed = true;
            if (track.signal_group >= 0 && scene.signals) {
                const double margin_m = a.length_m / 2 + 1.0;
                allowed = scene.signals->green_during(
                    track.signal_group, t + (track.conflict_begin_m - margin_m) / track.speed_mps,
                    t + (track.conflict_end_m + margin_m) / track.speed_mps);
            }
            if (allowed) {
                agents_.push_back(a);
                prev_length = a.length_m;
            }
            const double headway = -mean * std::log(1.0 - rng.uniform());
            t += std::max(min_dt, headway);
        }
    }
}

Eigen::Isometry3d Traffic::agent_pose(const Agent& a, double t_s) const {
    const Track& track = scene_->tracks[static_cast<std::size_t>(a.track)];
    const double s = (t_s - a.enter_time_s) * track.speed_mps;
    const Eigen::Vector2d p = track.path.position(s);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(p.x(), p.y(), track.z_m);
    T.linear() =
        Eigen::AngleAxisd(track.path.heading(s), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return T;
}

void Traffic::moving_boxes(double t0_s, double t1_s, std::vector<MovingBox>* out) const {
    out->clear();
    for (const Agent& a : agents_) {
        const Track& track = scene_->tracks[static_cast<std::size_t>(a.track)];
        const double s0 = (t0_s - a.enter_time_s) * track.speed_mps;
        const double s1 = (t1_s - a.enter_time_s) * track.speed_mps;
        if (s1 < 0.0 || s0 > track.path.length()) continue;
        const Eigen::Isometry3d A0 = agent_pose(a, t0_s), A1 = agent_pose(a, t1_s);
        for (const Part& part : parts(a.cls, a.length_m)) {
            MovingBox b;
            b.T_world_box_t0 = A0 * Eigen::Translation3d(part.centre);
            b.T_world_box_t1 = A1 * Eigen::Translation3d(part.centre);
            b.half_m = part.half;
            b.material = part.painted ? a.paint : unpainted(a.cls);
            out->push_back(b);
        }
    }
}

}  // namespace lidarfuse::sim
