#pragma once
// Fault injection for reliability tests: what goes wrong on a real station's network and
// sensors, applied to the simulated packet stream. Seeded per packet (seed, sensor, packet
// sequence number), so a faulty capture is as reproducible as a clean one.
//
// Command-line syntax (`lidarfuse sim --fault SPEC`, repeatable):
//   drop:SHARE[:SENSOR]          drop that share (0..1) of lidar packets
//   reorder:SHARE[:SENSOR]       swap that share of packets with the sensor's next packet
//   duplicate:SHARE[:SENSOR]     send that share of packets twice
//   truncate:SHARE[:SENSOR]      cut that share of packets to a random shorter length
//   init-id:SENSOR:AT_S          sensor "reboots" at AT_S seconds: new init_id from then on
//                                (visible in non-LEGACY headers only; LEGACY has none)
//   silence:SENSOR:FROM_S:DUR_S  sensor sends nothing in [FROM_S, FROM_S + DUR_S)
//   clock-offset:SENSOR:OFFSET_S add OFFSET_S to the sensor's packet timestamps
// SENSOR is a sensor name (lidar0, lidar1, ...); without it a rate applies to all sensors.

#include <cstdint>
#include <string>
#include <vector>

namespace lidarfuse::sim {

struct FaultRate {
    double share = 0.0;
    int sensor = -1;  // -1: every sensor
    bool applies(int s) const { return share > 0 && (sensor < 0 || sensor == s); }
};

struct FaultPlan {
    FaultRate drop, reorder, duplicate, truncate;
    struct InitIdChange {
        int sensor;
        double at_s;
    };
    struct Silence {
        int sensor;
        double from_s;
        double duration_s;
    };
    struct ClockOffset {
        int sensor;
        double offset_s;
    };
    std::vector<InitIdChange> init_id_changes;
    std::vector<Silence> silences;
    std::vector<ClockOffset> clock_offsets;

    bool empty() const;
    // Sensor-side faults, used while encoding.
    std::int64_t clock_offset_ns(int sensor) const;
    // init_id the sensor reports at time t_s (changes after each reboot).
    std::uint32_t init_id_at(int sensor, std::uint32_t initial, double t_s) const;
    bool silenced(int sensor, double t_s) const;
};

// Adds one SPEC (syntax above) to `plan`; sensor names are lidar0..lidar{sensors-1}.
// Throws std::invalid_argument naming the spec and what is wrong.
void parse_fault(const std::string& spec, int sensors, FaultPlan* plan);

// What happens to one packet on the network side.
struct PacketFate {
    bool drop = false;
    bool duplicate = false;
    bool reorder = false;         // hold it and send it after the sensor's next packet
    std::size_t truncate_to = 0;  // 0 = keep the full size
};

PacketFate packet_fate(const FaultPlan& plan, std::uint64_t seed, int sensor,
                       std::uint64_t sequence, double t_s, std::size_t size);

}  // namespace lidarfuse::sim
