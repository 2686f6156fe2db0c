#include "drivers/ouster/sensor_router.hpp"

#include <stdexcept>
#include <string>

namespace lidarfuse::ouster {

SensorRouter::SensorRouter(const std::vector<RoutedSensor>& sensors) {
    sensors_.reserve(sensors.size());
    learnt_.reserve(sensors.size() * 2);
    for (std::size_t i = 0; i < sensors.size(); ++i) {
        const auto& s = sensors[i];
        sensors_.push_back(Entry{PacketFormat(s.info), s.info.serial_number(),
                                 s.info.udp_port_lidar, s.info.udp_port_imu});
        if (s.source_ip) {
            if (bound(*s.source_ip) != kUnassigned) {
                throw std::invalid_argument("sensor router: two sensors claim source address " +
                                            std::to_string(*s.source_ip) + " (sensor " +
                                            std::to_string(i) + ")");
            }
            configured_.push_back({*s.source_ip, static_cast<int>(i)});
        }
    }
}

int SensorRouter::bound(std::uint32_t ip) const {
    for (const auto& b : configured_) {
        if (b.ip == ip) return b.sensor;
    }
    for (const auto& b : learnt_) {
        if (b.ip == ip) return b.sensor;
    }
    return kUnassigned;
}

void SensorRouter::learn(std::uint32_t ip, int sensor) {
    for (auto& b : configured_) {
        if (b.ip == ip) return;  // configuration wins
    }
    for (auto& b : learnt_) {
        if (b.ip == ip) {
            b.sensor = sensor;  // the serial said otherwise: the latest evidence wins
            return;
        }
    }
    learnt_.push_back({ip, sensor});
}

// The rules of sensor_router.hpp, in order; each helper answers kUnassigned when its rule
// does not decide.
int SensorRouter::route(std::uint32_t src_ip, std::uint16_t dst_port, const std::uint8_t* data,
                        std::size_t size) {
    ++counters_.datagrams;
    int only_candidate = kUnassigned;
    const int port_candidates = on_port_count(dst_port, &only_candidate);
    if (port_candidates == 0) return counted(kUnassigned, &counters_.unassigned);
    const int configured = configured_source(src_ip, dst_port);
    if (configured != kUnassigned) return counted(configured, &counters_.by_source);
    const int by_serial = serial_owner(dst_port, data, size);
    if (by_serial != kUnassigned) {
        learn(src_ip, by_serial);
        return counted(by_serial, &counters_.by_serial);
    }
    const int learnt = bound(src_ip);
    if (learnt != kUnassigned && on_port(sensors_[learnt], dst_port))
        return counted(learnt, &counters_.by_source);
    int lidar_matches = 0;
    const int by_lidar_size = size_match(dst_port, size, false, &lidar_matches);
    if (lidar_matches == 1) {
        learn(src_ip, by_lidar_size);
        return counted(by_lidar_size, &counters_.by_size);
    }
    if (lidar_matches == 0) {
        int imu_matches = 0;
        const int by_imu_size = size_match(dst_port, size, true, &imu_matches);
        if (imu_matches == 1) return counted(by_imu_size, &counters_.by_size);
    }
    if (port_candidates == 1) return counted(only_candidate, &counters_.by_port_only);
    return counted(kUnassigned, &counters_.unassigned);
}

int SensorRouter::on_port_count(std::uint16_t dst_port, int* last) const {
    int count = 0;
    for (int i = 0; i < static_cast<int>(sensors_.size()); ++i) {
        if (on_port(sensors_[i], dst_port)) {
            ++count;
            *last = i;
        }
    }
    return count;
}

int SensorRouter::configured_source(std::uint32_t src_ip, std::uint16_t dst_port) const {
    for (const auto& b : configured_) {
        if (b.ip == src_ip && on_port(sensors_[b.sensor], dst_port)) return b.sensor;
    }
    return kUnassigned;
}

int SensorRouter::serial_owner(std::uint16_t dst_port, const std::uint8_t* data,
                               std::size_t size) const {
    for (int i = 0; i < static_cast<int>(sensors_.size()); ++i) {
        const Entry& e = sensors_[i];
        if (!on_port(e, dst_port) || e.serial == 0 ||
            e.format.header_type() == HeaderType::kLegacy || size != e.format.lidar_packet_size() ||
            e.format.classify(data, size) != PacketKind::kLidar) {
            continue;
        }
        if (e.format.prod_sn(data) == e.serial) return i;
    }
    return kUnassigned;
}

int SensorRouter::size_match(std::uint16_t dst_port, std::size_t size, bool imu,
                             int* matches) const {
    int match = kUnassigned;
    for (int i = 0; i < static_cast<int>(sensors_.size()); ++i) {
        const PacketFormat& f = sensors_[i].format;
        if (on_port(sensors_[i], dst_port) &&
            (imu ? f.imu_packet_size() : f.lidar_packet_size()) == size) {
            ++*matches;
            match = i;
        }
    }
    return match;
}

}  // namespace lidarfuse::ouster
