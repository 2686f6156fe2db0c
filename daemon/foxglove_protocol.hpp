#pragma once
// The messages of the Foxglove WebSocket protocol (foxglove.websocket.v1) that lidarfused's
// server speaks, without any networking: JSON text for serverInfo, advertise and status,
// the client's subscribe / unsubscribe parsed, and the binary message-data frame.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "daemon/foxglove_schemas.hpp"

namespace lidarfuse::daemon {

inline constexpr std::uint8_t kFoxgloveMessageDataOpcode = 0x01;
// opcode, subscription id (u32), receive time (u64)
inline constexpr std::size_t kFoxgloveMessageDataHeaderBytes = 1 + 4 + 8;

enum class FoxgloveStatusLevel { kInfo = 0, kWarning = 1, kError = 2 };

// No capabilities (clients cannot publish, call services or set parameters).
std::string foxglove_server_info(const std::string& name, const std::string& session_id);
// Every channel with encoding "cdr" and schemaEncoding "ros2msg".
std::string foxglove_advertise(const std::vector<FoxgloveChannelInfo>& channels);
std::string foxglove_status(FoxgloveStatusLevel level, const std::string& message);

struct FoxgloveRequest {
    enum class Kind { kSubscribe, kUnsubscribe, kInvalid };
    Kind kind = Kind::kInvalid;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> subscribe;  // (subscription, channel)
    std::vector<std::uint32_t> unsubscribe;                          // subscription ids
    std::string error;  // kInvalid: why, for a status message back to the client
};

// A text message from a client. Malformed JSON, unknown ops and ids outside u32 give
// kInvalid with the reason; never throws.
FoxgloveRequest parse_foxglove_request(const std::string& text);

// The binary frame of one message for one subscription, into `frame` (reused).
void foxglove_message_data(std::uint32_t subscription_id, std::uint64_t receive_ns,
                           const std::vector<std::uint8_t>& payload, std::string* frame);

}  // namespace lidarfuse::daemon
