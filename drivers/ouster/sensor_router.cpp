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

int SensorRouter::route(std::uint32_t src_ip, std::uint16_t dst_port, const std::uint8_t* data,
                        std::size_t size) {
    ++counters_.datagrams;
    const int n = static_cast<int>(sensors_.size());
    int port_candidates = 0;
    int last_port_candidate = kUnassigned;
    for (int i = 0; i < n; ++i) {
        if (on_port(sensors_[i], dst_port)) {
            ++port_candidates;
            last_port_candidate = i;
        }
    }
    if (port_candidates == 0) {
        ++counters_.unassigned;
        return kUnassigned;
    }
    for (const auto& b : configured_) {
        if (b.ip == src_ip && on_port(sensors_[b.sensor], dst_port)) {
            ++counters_.by_source;
            return b.sensor;
        }
    }
    for (int i = 0; i < n; ++i) {
        const Entry& e = sensors_[i];
        if (!on_port(e, dst_port) || e.serial == 0 ||
            e.format.header_type() == HeaderType::kLegacy || size != e.format.lidar_packet_size() ||
            e.format.classify(data, size) != PacketKind::kLidar) {
            continue;
        }
        if (e.format.prod_sn(data) == e.serial) {
            learn(src_ip, i);
            ++counters_.by_serial;
            return i;
        }
    }
    const int learnt = bound(src_ip);
    if (learnt != kUnassigned && on_port(sensors_[learnt], dst_port)) {
        ++counters_.by_source;
        return learnt;
    }
    int match = kUnassigned;
    int matches = 0;
    for (int i = 0; i < n; ++i) {
        if (on_port(sensors_[i], dst_port) && sensors_[i].format.lidar_packet_size() == size) {
            ++matches;
            match = i;
        }
    }
    if (matches == 1) {
        learn(src_ip, match);
        ++counters_.by_size;
        return match;
    }
    if (matches == 0) {
        for (int i = 0; i < n; ++i) {
            if (on_port(sensors_[i], dst_port) && sensors_[i].format.imu_packet_size() == size) {
                ++matches;
                match = i;
            }
        }
        if (matches == 1) {
            ++counters_.by_size;
            return match;
        }
    }
    if (port_candidates == 1) {
        ++counters_.by_port_only;
        return last_port_candidate;
    }
    ++counters_.unassigned;
    return kUnassigned;
}

}  // namespace lidarfuse::ouster
