#pragma once

#include <cstdint>
#include <string>

namespace lidarfuse::daemon {

// What SensorStats (pipeline.hpp) shows of a sensor whose clouds come from DDS
// (daemon/dds_input.hpp).
struct DdsInputStatus {
    std::string topic;
    int domain_id = 0;
    int publishers = 0;                   // writers matched now
    std::uint64_t clouds = 0;             // readable clouds taken from the reader
    std::uint64_t refused = 0;            // layout, frame, stamp or no points (last_error says)
    std::uint64_t non_finite_points = 0;  // skipped in the clouds taken
    std::string frame_id;                 // the first cloud's; "" before it
    // Why a cloud was refused, naming the sensor and topic: the newest of this input's own
    // refusals (stamp, frame, no finite point), else the reader's newest (layout).
    std::string last_error;
};

}  // namespace lidarfuse::daemon
