#pragma once
// lidarfused's status line: the systemd STATUS= text while it runs and the "stopped: ..."
// log line at the end. Frames fused, time per frame, frames dropped and not yet published,
// and every sensor's state with the reason it is not OK.
#include <string>
#include <vector>

#include "daemon/pipeline.hpp"

namespace lidarfuse::daemon {

// Why a sensor is in its state: the age of its last scan when it is STALE or LOST, the mode
// it sends when that disagrees with its metadata, how far its clock is from the root's;
// empty when OK or disabled.
std::string sensor_reason(const SensorStats& sensor);

// A CLOCK_SKEW sensor's reason, from its clock minus the root's (ms): "clock 5.012 s ahead of
// the root's", "clock 1.500 s behind the root's".
std::string clock_skew_reason(double skew_ms);

// "4 OK", or "3 OK; 1 LOST: last scan 3.1 s ago (lidar2)": one group per state, the reason
// said once when every member shares it; the members are named unless all are OK.
std::string sensors_summary(const std::vector<SensorStats>& sensors);

// "fused 173 frames, 50.0 ms/frame, 27 dropped, 75 unpublished (before the road world
// frame); sensors: 4 OK"
std::string status_line(const PipelineStats& stats);

}  // namespace lidarfuse::daemon
