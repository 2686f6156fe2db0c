#pragma once
// Decides which of several configured sensors a UDP datagram comes from, when sensors
// share a destination port (Ouster's same_ports setups) or a capture holds several.
//
// Rule, in this order (the first that decides wins):
//  1. Port: only sensors whose udp_port_lidar or udp_port_imu equals the destination port
//     are candidates. No candidate: unassigned.
//  2. Configured source address: a sensor given `source_ip` owns every datagram from that
//     address (and no other sensor may claim that address).
//  3. Header serial: for a candidate whose profile has a STANDARD or FUSA header, a
//     datagram of exactly its lidar packet size, classified as lidar by its format, whose
//     header prod_sn equals the metadata serial, is that sensor's. (Two profiles may have
//     the same packet size, e.g. RNG19 dual x64 and FUSA dual x128 are both 16,640 B: only
//     the header, read at each format's own offsets, tells them apart.) The source
//     address is then learnt for that sensor.
//  4. Learnt source address: a datagram from an address learnt in 3 or 5 goes to that
//     sensor. This is how IMU packets (no serial) and LEGACY packets find their sensor.
//  5. Size: the candidates whose lidar packet size equals the datagram size (for LEGACY,
//     which carries no serial, this is the only evidence); if exactly one, it is chosen
//     and the address learnt. Else the candidates whose IMU size matches, and if exactly
//     one, it is chosen (not learnt: IMU sizes are all 48 B).
//  6. A single candidate left by the port rule gets the datagram even if nothing else
//     matched (its assembler then counts the wrong size). Otherwise: unassigned.
// Two LEGACY sensors of the same model on one port are therefore told apart only by a
// configured source_ip; without one their packets are ambiguous and counted unassigned,
// never guessed.
// Likewise an IMU packet (48 B, no serial) that arrives on a shared port before any lidar
// packet of its sensor has taught the router its address is unassigned (same_ports.pcap
// starts with two of them).
//
// Learning allocates only when a new source address appears (bounded by the number of
// sensors: an address is learnt once). Not thread safe.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "drivers/ouster/metadata.hpp"
#include "drivers/ouster/packet_format.hpp"

namespace lidarfuse::ouster {

struct RoutedSensor {
    SensorInfo info;
    std::optional<std::uint32_t> source_ip;  // IPv4, host byte order
};

struct RouterCounters {
    std::uint64_t datagrams = 0;
    std::uint64_t by_source = 0;     // rule 2 or 4
    std::uint64_t by_serial = 0;     // rule 3
    std::uint64_t by_size = 0;       // rule 5
    std::uint64_t by_port_only = 0;  // rule 6
    std::uint64_t unassigned = 0;    // no sensor on the port, or ambiguous
};

class SensorRouter {
public:
    static constexpr int kUnassigned = -1;

    // Throws std::invalid_argument when two sensors claim the same source_ip.
    explicit SensorRouter(const std::vector<RoutedSensor>& sensors);

    // Index into the constructor's sensor list, or kUnassigned.
    int route(std::uint32_t src_ip, std::uint16_t dst_port, const std::uint8_t* data,
              std::size_t size);

    const RouterCounters& counters() const { return counters_; }
    std::size_t size() const { return sensors_.size(); }

private:
    struct Entry {
        PacketFormat format;
        std::uint64_t serial;  // 0 when the metadata has none
        std::uint16_t port_lidar;
        std::uint16_t port_imu;
    };
    struct Binding {
        std::uint32_t ip;
        int sensor;
    };
    bool on_port(const Entry& e, std::uint16_t port) const {
        return e.port_lidar == port || e.port_imu == port;
    }
    int bound(std::uint32_t ip) const;
    void learn(std::uint32_t ip, int sensor);
    // route's steps, defined in sensor_router.cpp (the only caller) and inlined there.
    static int counted(int sensor, std::uint64_t* counter) {
        ++*counter;
        return sensor;
    }
    // Rule 1: how many sensors listen on the port, and the last of them.
    inline int on_port_count(std::uint16_t dst_port, int* last) const;
    // Rule 2: the sensor configured with this source address, if it is on the port.
    inline int configured_source(std::uint32_t src_ip, std::uint16_t dst_port) const;
    // Rule 3: the first sensor on the port whose serial the lidar packet's header carries.
    inline int serial_owner(std::uint16_t dst_port, const std::uint8_t* data,
                            std::size_t size) const;
    // Rule 5: the last sensor on the port whose lidar (or IMU) packet has this size, and how
    // many have it (added to *matches).
    inline int size_match(std::uint16_t dst_port, std::size_t size, bool imu, int* matches) const;

    std::vector<Entry> sensors_;
    std::vector<Binding> configured_;
    std::vector<Binding> learnt_;
    RouterCounters counters_;
};

}  // namespace lidarfuse::ouster
