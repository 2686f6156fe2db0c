#include "daemon/status_line.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace lidarfuse::daemon {

std::string clock_skew_reason(double skew_ms) {
    char buffer[96];
    std::snprintf(buffer, sizeof(buffer), "clock %.3f s %s the root's", std::abs(skew_ms) / 1e3,
                  skew_ms >= 0 ? "ahead of" : "behind");
    return buffer;
}

std::string sensor_reason(const SensorStats& s) {
    char buffer[96];
    switch (s.state) {
        case SensorState::kOk:
        case SensorState::kDisabled:
            return "";
        case SensorState::kModeMismatch:
            return "sends " + s.mode_seen;
        case SensorState::kClockSkew:
            return clock_skew_reason(s.clock_skew_ms);
        case SensorState::kNoMetadata:
            return s.metadata.last_error.empty() ? "fetching from " + s.metadata.source
                                                 : s.metadata.last_error;
        case SensorState::kStale:
        case SensorState::kLost:
            if (s.ms_since_last_scan < 0)
                return s.packets > 0 ? "packets but no scan yet" : "nothing received";
            std::snprintf(buffer, sizeof(buffer), "last scan %.1f s ago",
                          s.ms_since_last_scan / 1e3);
            return buffer;
    }
    return "";
}

std::string sensors_summary(const std::vector<SensorStats>& sensors) {
    std::string text;
    for (const SensorState state :
         {SensorState::kOk, SensorState::kStale, SensorState::kLost, SensorState::kModeMismatch,
          SensorState::kClockSkew, SensorState::kNoMetadata, SensorState::kDisabled}) {
        std::vector<const SensorStats*> group;
        for (const auto& s : sensors) {
            if (s.state == state) group.push_back(&s);
        }
        if (group.empty()) continue;
        const std::string first_reason = sensor_reason(*group.front());
        bool shared = true;
        for (const auto* s : group) shared = shared && sensor_reason(*s) == first_reason;
        text += (text.empty() ? "" : "; ") + std::to_string(group.size()) + " " + to_string(state);
        if (shared && !first_reason.empty()) text += ": " + first_reason;
        if (group.size() == sensors.size() && state == SensorState::kOk) continue;
        std::string members;
        for (const auto* s : group) {
            const std::string why = shared ? "" : sensor_reason(*s);
            members += (members.empty() ? "" : ", ") + s->name + (why.empty() ? "" : ": " + why);
        }
        text += " (" + members + ")";
    }
    return text;
}

std::string status_line(const PipelineStats& st) {
    char buffer[320];
    // Frames fused before the world frame was known (road: the initial registration) are
    // not published: "N unpublished" says how many.
    std::snprintf(buffer, sizeof(buffer),
                  "fused %llu frames (%llu at predicted poses), %.1f ms/frame, %llu dropped, %llu "
                  "unpublished (before the %s world frame); sensors: ",
                  static_cast<unsigned long long>(st.frames_fused),
                  static_cast<unsigned long long>(st.frames_predicted), st.mean_fusion_ms,
                  static_cast<unsigned long long>(st.frame_queue_drops + st.scan_queue_drops),
                  static_cast<unsigned long long>(st.frames_before_world_frame),
                  st.world_frame.c_str());
    return buffer + sensors_summary(st.sensors);
}

}  // namespace lidarfuse::daemon
