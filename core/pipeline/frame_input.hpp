#pragma once
// A synchronised frame of scans as FusionEngine's input: each member's points, times and
// intensities are moved into its sensor's slot, an absent member leaves the slot absent.
// `Scan` is any type with t_ns, points, point_dt_s and intensity as in SensorScanInput
// (the daemon's scan messages, the offline tools' decoded scans).

#include <cstddef>
#include <utility>

#include "core/pipeline/frame_synchroniser.hpp"
#include "core/pipeline/fusion_types.hpp"

namespace lidarfuse::core {

template <typename Scan>
FrameInput frame_input(SyncedFrame<Scan>* frame, std::size_t num_sensors) {
    FrameInput input;
    input.sensors.resize(num_sensors);
    for (std::size_t s = 0; s < num_sensors && s < frame->members.size(); ++s) {
        auto& member = frame->members[s];
        if (!member) continue;
        SensorScanInput& in = input.sensors[s];
        in.present = true;
        in.t_ns = member->t_ns;
        in.points = std::move(member->points);
        in.point_dt_s = std::move(member->point_dt_s);
        in.intensity = std::move(member->intensity);
    }
    return input;
}

}  // namespace lidarfuse::core
