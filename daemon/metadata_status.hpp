#pragma once

#include <cstdint>
#include <string>

namespace lidarfuse::daemon {

// Where a sensor's metadata comes from and, for a sensor named by hostname, what its
// fetcher did last (daemon/metadata_fetcher.hpp).
struct MetadataStatus {
    std::string source;      // the file, or http://host:port
    std::string endpoint;    // the path that answered the last fetch
    std::string last_error;  // of the last failed attempt; "" after a success
    std::uint64_t fetches = 0, failures = 0, changes = 0, configured = 0;
};

}  // namespace lidarfuse::daemon
