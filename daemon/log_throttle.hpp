#pragma once
// A problem that repeats at every datagram, cloud or scan (a flood of bad input, a sensor
// whose clock is off) must not flood the log: its 1st, 2nd, 4th, 8th ... occurrence is
// logged, with the count so far, and every one is counted.

#include <cstdint>

namespace lidarfuse::daemon {

// Whether the `count`-th occurrence (counting from 1) is one to log.
inline bool logged_occurrence(std::uint64_t count) {
    return count != 0 && (count & (count - 1)) == 0;
}

}  // namespace lidarfuse::daemon
