#include "daemon/clock_check.hpp"

namespace lidarfuse::daemon {

ClockCheck::ClockCheck(std::size_t sensors, std::size_t root, std::int64_t max_skew_ns)
    : sensors_(sensors), root_(root), max_skew_ns_(max_skew_ns) {}

std::optional<std::int64_t> ClockCheck::refuse(std::size_t sensor, std::int64_t t_ns,
                                               std::int64_t steady_ns) {
    if (max_skew_ns_ <= 0 || sensor >= sensors_) return std::nullopt;
    const std::int64_t offset_ns = t_ns - steady_ns;
    if (sensor == root_) {
        root_offset_ns_ = offset_ns;
        return std::nullopt;
    }
    if (!root_offset_ns_) return std::nullopt;
    const std::int64_t skew_ns = offset_ns - *root_offset_ns_;
    if (skew_ns <= max_skew_ns_ && skew_ns >= -max_skew_ns_) return std::nullopt;
    return skew_ns;
}

}  // namespace lidarfuse::daemon
