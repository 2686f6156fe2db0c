#include "daemon/frame_stamps.hpp"

namespace lidarfuse::daemon {

FrameStamps frame_stamps(const core::FrameOutput& frame, StampSource source,
                         const std::vector<std::int64_t>& host_ns) {
    FrameStamps out;
    out.sensor_ns.assign(frame.health.size(), 0);
    std::int64_t earliest_registered = 0, earliest = 0;
    for (std::size_t s = 0; s < frame.health.size() && s < frame.t_ns.size(); ++s) {
        if (!frame.health[s].included) continue;
        const std::int64_t t =
            source == StampSource::kSensor ? frame.t_ns[s] : (s < host_ns.size() ? host_ns[s] : 0);
        if (t <= 0) continue;
        out.sensor_ns[s] = t;
        if (earliest == 0 || t < earliest) earliest = t;
        if (frame.health[s].pose_valid && (earliest_registered == 0 || t < earliest_registered))
            earliest_registered = t;
    }
    out.frame_ns = earliest_registered > 0 ? earliest_registered : earliest;
    return out;
}

}  // namespace lidarfuse::daemon
