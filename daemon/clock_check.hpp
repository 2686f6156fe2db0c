#pragma once
// Whether a sensor's clock agrees with the root sensor's, before its scans are synchronised.
//
// The synchroniser groups scans by their timestamps (core/pipeline/frame_synchroniser.hpp),
// so it needs one time base. A sensor whose clock is off by seconds (not PTP-synchronised, an
// OS1 left on TIME_FROM_INTERNAL_OSC beside synchronised ones, a station whose clock is
// wrong) would break it for every sensor: scans ahead of the others' open frames that leave
// first, after which the others' scans count as late and are dropped; scans 2 s ahead or
// behind reset it at every scan (sync.reset_jump_ms). So each scan's clock is compared with
// the root's first, and a scan that disagrees by more than sync.max_clock_skew_ms is refused
// (counted, the sensor reported CLOCK_SKEW) while the others go on.
//
// A clock is compared through its offset to the host's steady clock when the scan completed
// (sensor time - steady time, ns): two synchronised sensors' offsets differ by their
// delivery latencies (a few ms for Ouster packets; a station's fused cloud arrives after its
// fusion, up to a few hundred ms), two unsynchronised ones' by their clocks' difference.
// The root is the reference (its frame is the fused one): with two sensors nothing else
// could tell which one is wrong. A sensor is refused from the first scan that disagrees:
// one that jumps alone (a 37 s TAI offset, PTP lost) would otherwise open frames ahead of
// the others or reset the synchroniser. When every clock jumps (a looped replay, a PTP
// step), the scans taken between the root's jump and another sensor's disagree and are
// refused too: at most a scan or two per sensor. With no reference yet (the root has sent
// nothing) every scan is taken.
//
// Sync thread only.

#include <cstddef>
#include <cstdint>
#include <optional>

namespace lidarfuse::daemon {

class ClockCheck {
public:
    // `max_skew_ns` <= 0 turns the check off.
    ClockCheck(std::size_t sensors, std::size_t root, std::int64_t max_skew_ns);

    // A scan of `sensor` with its timestamp (sensor clock, after time_offset_ns) completed at
    // host steady time `steady_ns`: its clock's offset from the root's (ns, positive when
    // ahead) when the scan is to be refused, nullopt when it is taken.
    std::optional<std::int64_t> refuse(std::size_t sensor, std::int64_t t_ns,
                                       std::int64_t steady_ns);

private:
    std::size_t sensors_;
    std::size_t root_;
    std::int64_t max_skew_ns_;
    std::optional<std::int64_t> root_offset_ns_;  // the root's at its latest scan
};

}  // namespace lidarfuse::daemon
