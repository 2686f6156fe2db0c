#pragma once
// lidarfused's live view: a Foxglove WebSocket server (protocol foxglove.websocket.v1) on a
// thread of its own, `lf-foxglove` (websocketpp on Debian's standalone asio). Foxglove, or
// its fork Lichtblick, connects to ws://<bind_address>:<port>, gets serverInfo and the
// channels advertised (daemon/foxglove_schemas.hpp), subscribes, and receives each message
// as a binary frame: opcode 0x01, subscription id (u32 LE), receive time (u64 LE, ns since
// the epoch, CLOCK_REALTIME), the message's CDR bytes.
//
// Never blocks its caller: publish() only hands the bytes to the server thread. Each
// client has a bounded send buffer (output.foxglove.client_buffer_mb); a message that would
// overfill it is dropped for that client and counted, so a slow or stalled client loses
// messages and nobody else waits. Bytes handed over but not yet sent are bounded by the
// same size: past it publish() drops the message (counted). At most max_clients clients;
// further connections are refused (HTTP 503) and counted.
//
// Threads: construct (binds the port; throws naming the address) and start()/stop() on
// one thread; publish(), wants() and stats() from any thread.

#include <spdlog/logger.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/common/counter_field.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/foxglove_schemas.hpp"

namespace lidarfuse::daemon {

struct FoxgloveClientStats {
    std::string peer;  // address:port
    std::uint64_t sent = 0;
    std::uint64_t dropped = 0;  // its send buffer was full
};

struct FoxgloveStats {
    bool enabled = false;
    int port = 0;
    std::uint64_t connections = 0;             // accepted since the start
    std::uint64_t refused = 0;                 // past max_clients (or without the subprotocol)
    std::uint64_t sent = 0, dropped = 0;       // messages, summed over every client ever connected
    std::uint64_t queue_drops = 0;             // dropped before any client: the hand-over was full
    std::vector<FoxgloveClientStats> clients;  // connected now
};

// Every counter of FoxgloveStats once, in the order of the diagnostics' values.
inline constexpr std::array<core::CounterField<FoxgloveStats>, 5> kFoxgloveCounters{{
    {"foxglove_connections", &FoxgloveStats::connections, "connections"},
    {"foxglove_refused", &FoxgloveStats::refused, "connections"},
    {"foxglove_messages_sent", &FoxgloveStats::sent, "messages"},
    {"foxglove_messages_dropped", &FoxgloveStats::dropped, "messages"},
    {"foxglove_queue_drops", &FoxgloveStats::queue_drops, "messages"},
}};

class FoxgloveServer {
public:
    static constexpr const char* kSubprotocol = "foxglove.websocket.v1";

    // Listens on config.bind_address:config.port (0: a free port, see port()). Throws
    // std::runtime_error naming the address when it cannot.
    FoxgloveServer(const FoxgloveConfig& config, std::vector<FoxgloveChannelInfo> channels,
                   std::string server_name, std::shared_ptr<spdlog::logger> log);
    ~FoxgloveServer();
    FoxgloveServer(const FoxgloveServer&) = delete;
    FoxgloveServer& operator=(const FoxgloveServer&) = delete;

    void start();
    // Closes every connection (a stalled one is cut after at most a second) and joins the
    // thread; idempotent.
    void stop();

    // A client is subscribed to `channel`, or it is latched (its last message is kept for
    // later subscribers): only then is a message worth building.
    bool wants(FoxgloveChannel channel) const;
    void publish(FoxgloveChannel channel, std::int64_t receive_ns,
                 std::shared_ptr<const std::vector<std::uint8_t>> payload);

    std::uint16_t port() const;
    FoxgloveStats stats() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace lidarfuse::daemon
