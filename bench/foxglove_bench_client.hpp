#pragma once
// daemon_latency_bench --foxglove client: a Node client (tests/foxglove/client.cjs, mode
// count) subscribed to every channel of lidarfused's live view. It reads every message and
// decodes none, so what the daemon spends is the server's cost, not a viewer's.
// Needs node and tests/foxglove/install.sh <build folder>.

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <string>

namespace lidarfuse::bench {

// The port lidarfused logged ("foxglove: live view on ws://ADDRESS:PORT"); 0 until then.
std::uint16_t foxglove_port_in_log(const std::filesystem::path& log);

struct FoxgloveCounts {
    long clouds = 0;
    double cloud_mib = 0.0;
    long messages = 0;
};

class FoxgloveBenchClient {
public:
    // Starts the client on ws://127.0.0.1:`port` and waits until it has subscribed. False
    // (with a line on stderr) when node or the client's packages are missing or it did not
    // subscribe within 60 s (node starts slowly on a loaded machine).
    bool start(std::uint16_t port, const std::filesystem::path& out);
    // Stops it (SIGTERM) and reads what it counted.
    FoxgloveCounts stop();
    ~FoxgloveBenchClient();

private:
    pid_t pid_ = 0;
    std::filesystem::path out_;
};

}  // namespace lidarfuse::bench
