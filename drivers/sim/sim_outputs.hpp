#pragma once
// Writes a simulation's files into a folder:
//   capture.pcap        every sensor's lidar packets (PcapWriter; IPv4 fragments at MTU
//                       1500 unless whole datagrams are asked for)
//   <sensor>.json       nested Ouster metadata per sensor
//   ground_truth.csv    frame,sensor,t_ns,x,y,z,qw,qx,qy,qz (T_world_sensor at each frame's
//                       timestamp; see drivers/io/pose_csv.hpp)
//   station.yaml        station name, root sensor, sensors (name, udp_port, metadata path
//                       relative to the folder); no poses
// With several stations (SimParams::stations), one such folder per station, station<j>/,
// holding that station's sensors only, named and numbered as in a simulation of it alone;
// every ground_truth.csv is in the one world frame of the road.
// Not real-time code: errors throw naming the file.

#include <filesystem>
#include <string>

#include "drivers/sim/simulator.hpp"

namespace lidarfuse::sim {

struct OutputOptions {
    bool fragment = true;      // false: whole datagrams (like a loopback capture)
    std::string station_name;  // empty: "sim-<scenario>"; several stations: "<name>-<j>"
};

// Metadata, station.yaml and ground_truth.csv (everything but the capture).
void write_description(const Simulator& sim, const std::filesystem::path& dir,
                       const OutputOptions& options);

// Everything, including capture.pcap (runs the simulation).
SimStats write_simulation(Simulator& sim, const std::filesystem::path& dir,
                          const OutputOptions& options);

}  // namespace lidarfuse::sim
