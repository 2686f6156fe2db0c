// lidarfused's status line (daemon/status_line.hpp): every sensor's state and why, read
// from constructed stats, so each state and each reason is checked exactly.
#include "daemon/status_line.hpp"

#include <gtest/gtest.h>

namespace lidarfuse::daemon {
namespace {

SensorStats sensor(const std::string& name, SensorState state, double ms_since_last_scan,
                   std::uint64_t packets = 100) {
    SensorStats s;
    s.name = name;
    s.state = state;
    s.ms_since_last_scan = ms_since_last_scan;
    s.packets = packets;
    return s;
}

TEST(StatusLine, AllOkIsCountedWithoutNames) {
    const std::vector<SensorStats> all = {sensor("a", SensorState::kOk, 10),
                                          sensor("b", SensorState::kOk, 12)};
    EXPECT_EQ(sensors_summary(all), "2 OK");
}

TEST(StatusLine, AReplayThatEndedSaysSoOnceForEverySensor) {
    const std::vector<SensorStats> all = {sensor("lidar0", SensorState::kLost, 3040),
                                          sensor("lidar1", SensorState::kLost, 3020)};
    EXPECT_EQ(sensors_summary(all), "2 LOST: last scan 3.0 s ago (lidar0, lidar1)");
}

TEST(StatusLine, MixedStatesNameTheSensorsThatAreNotOkWithTheirOwnReasons) {
    SensorStats mismatch = sensor("lidar3", SensorState::kModeMismatch, 20);
    mismatch.mode_seen = "2048x10";
    const std::vector<SensorStats> all = {sensor("lidar0", SensorState::kOk, 10),
                                          sensor("lidar1", SensorState::kStale, 400),
                                          sensor("lidar2", SensorState::kLost, -1, 0),
                                          sensor("lidar4", SensorState::kLost, -1, 7),
                                          mismatch,
                                          sensor("lidar5", SensorState::kDisabled, -1, 0)};
    EXPECT_EQ(sensors_summary(all),
              "1 OK (lidar0); 1 STALE: last scan 0.4 s ago (lidar1); 2 LOST (lidar2: nothing "
              "received, lidar4: packets but no scan yet); 1 MODE_MISMATCH: sends 2048x10 "
              "(lidar3); 1 DISABLED (lidar5)");
}

TEST(StatusLine, ASensorWithoutMetadataSaysWhyOrWhereItIsFetchedFrom) {
    SensorStats failing = sensor("lidar1", SensorState::kNoMetadata, -1, 0);
    failing.metadata.source = "http://10.5.6.12:80";
    failing.metadata.last_error = "host 10.5.6.12:80 GET /api/v1/sensor/metadata: timed out";
    SensorStats first = sensor("lidar2", SensorState::kNoMetadata, -1, 0);
    first.metadata.source = "http://10.5.6.13:80";
    EXPECT_EQ(sensors_summary({sensor("lidar0", SensorState::kOk, 10), failing, first}),
              "1 OK (lidar0); 2 NO_METADATA (lidar1: host 10.5.6.12:80 GET "
              "/api/v1/sensor/metadata: timed out, lidar2: fetching from http://10.5.6.13:80)");
}

TEST(StatusLine, TheWholeLineKeepsItsCountersFirst) {
    PipelineStats st;
    st.frames_fused = 173;
    st.frames_predicted = 40;
    st.mean_fusion_ms = 50.04;
    st.frame_queue_drops = 20;
    st.scan_queue_drops = 7;
    st.frames_before_world_frame = 75;
    st.world_frame = "road";
    st.sensors = {sensor("lidar0", SensorState::kOk, 5)};
    EXPECT_EQ(status_line(st),
              "fused 173 frames (40 at predicted poses), 50.0 ms/frame, 27 dropped, 75 unpublished "
              "(before the road world frame); sensors: 1 OK");
}

}  // namespace
}  // namespace lidarfuse::daemon
