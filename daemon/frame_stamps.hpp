#pragma once
// The stamps of one fused frame's messages (clouds, rt/tf, poses), one rule for all of them
// so a ROS 2 consumer can look every sensor up at a cloud's stamp:
//
// - a sensor's stamp is its own scan's time in this frame: the sensors' clock
//   (`output.stamp: sensor`, PTP-synchronised stations), or CLOCK_REALTIME when the
//   scan's last packet was received (`host`, for sensors whose clock is not the host's);
// - a sensor without a scan in the frame has no stamp (0 here) and is left out of that
//   frame's tf: a stamp 0 reads as "the beginning of time" to tf2 (TF_OLD_DATA);
// - the frame's stamp (clouds, poses' header) is the earliest stamp of its registered
//   sensors (those on tf and in the cloud; of all its sensors when none is registered).
//   tf2 interpolates a moving frame between two samples and never extrapolates: at that
//   stamp every sensor on the frame's tf has a sample at or after it (this frame's), and,
//   from its second frame on tf, one before it (an earlier frame's: a frame's members are
//   at most one frame period apart, sync.max_offset_ms), so the lookup resolves.

#include <cstdint>
#include <vector>

#include "core/pipeline/fusion_types.hpp"
#include "daemon/daemon_config.hpp"

namespace lidarfuse::daemon {

struct FrameStamps {
    std::vector<std::int64_t> sensor_ns;  // ns per sensor; 0 = not in this frame
    std::int64_t frame_ns = 0;            // ns; 0 = no sensor in the frame (nothing to publish)
};

// `host_ns`: per sensor, CLOCK_REALTIME when that sensor's scan in this frame was
// received (its last packet), 0 when unknown; read only for StampSource::kHost. A stamp
// that is not positive counts as unknown.
FrameStamps frame_stamps(const core::FrameOutput& frame, StampSource source,
                         const std::vector<std::int64_t>& host_ns);

}  // namespace lidarfuse::daemon
