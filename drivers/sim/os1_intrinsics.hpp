#pragma once
// Beam intrinsics of a real Ouster OS1-64 (an OS-1-64-AH, FW v2.5.2): the numbers of
// ouster-sdk tests/pcaps/same_ports_legacy.2.json (BSD 3-Clause, Ouster, Inc.; see
// ../shared/data/ouster/SOURCES.md), embedded so that the simulator works where the sample
// data is absent. A test compares them with the file when it is present.
// Angles in degrees (altitude: + up; azimuth: Ouster's sign convention), lengths in mm.

#include <array>

namespace lidarfuse::sim::os1_64 {

constexpr int kBeams = 64;
extern const std::array<double, kBeams> kBeamAltitudeDeg;
extern const std::array<double, kBeams> kBeamAzimuthDeg;
constexpr double kLidarOriginToBeamOriginMm = 15.806;
// beam_to_lidar_transform: identity rotation, translation (15.806, 0, 0) mm.
// lidar_to_sensor_transform: diag(-1, -1, 1), translation (0, 0, 36.18) mm.
constexpr double kLidarToSensorZMm = 36.18;
// imu_to_sensor_transform translation, mm.
constexpr std::array<double, 3> kImuToSensorMm = {6.253, -11.775, 7.645};
constexpr const char* kProdLine = "OS-1-64-AH";
constexpr const char* kProdPn = "840-104816-06";
constexpr const char* kBuildRev = "v2.5.2";
constexpr const char* kImageRev = "ousteros-image-prod-aries-v2.5.2+20230714195410";

}  // namespace lidarfuse::sim::os1_64
