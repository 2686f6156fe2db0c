#include "daemon/foxglove_protocol.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

namespace lidarfuse::daemon {

namespace {

using Json = nlohmann::json;

// A JSON number that is a whole number in 0..2^32-1 (ids are u32 in the protocol).
bool read_u32(const Json& value, std::uint32_t* out) {
    if (!value.is_number_unsigned()) return false;
    const auto v = value.get<std::uint64_t>();
    if (v > 0xFFFFFFFFull) return false;
    *out = static_cast<std::uint32_t>(v);
    return true;
}

FoxgloveRequest invalid(std::string why) {
    FoxgloveRequest r;
    r.error = std::move(why);
    return r;
}

FoxgloveRequest parse_subscribe(const Json& message) {
    const auto it = message.find("subscriptions");
    if (it == message.end() || !it->is_array()) return invalid("subscribe: no subscriptions array");
    FoxgloveRequest r;
    r.kind = FoxgloveRequest::Kind::kSubscribe;
    for (const auto& s : *it) {
        std::uint32_t id = 0, channel = 0;
        if (!s.is_object() || !s.contains("id") || !s.contains("channelId") ||
            !read_u32(s["id"], &id) || !read_u32(s["channelId"], &channel)) {
            return invalid("subscribe: each subscription needs u32 id and channelId");
        }
        r.subscribe.emplace_back(id, channel);
    }
    return r;
}

FoxgloveRequest parse_unsubscribe(const Json& message) {
    const auto it = message.find("subscriptionIds");
    if (it == message.end() || !it->is_array()) {
        return invalid("unsubscribe: no subscriptionIds array");
    }
    FoxgloveRequest r;
    r.kind = FoxgloveRequest::Kind::kUnsubscribe;
    for (const auto& s : *it) {
        std::uint32_t id = 0;
        if (!read_u32(s, &id)) return invalid("unsubscribe: subscription ids are u32");
        r.unsubscribe.push_back(id);
    }
    return r;
}

void put_le(std::uint64_t value, int bytes, char* out) {
    for (int i = 0; i < bytes; ++i) out[i] = static_cast<char>((value >> (8 * i)) & 0xFF);
}

}  // namespace

std::string foxglove_server_info(const std::string& name, const std::string& session_id) {
    return Json{{"op", "serverInfo"},
                {"name", name},
                {"capabilities", Json::array()},
                {"supportedEncodings", Json::array()},
                {"metadata", Json::object()},
                {"sessionId", session_id}}
        .dump();
}

std::string foxglove_advertise(const std::vector<FoxgloveChannelInfo>& channels) {
    Json list = Json::array();
    for (const auto& c : channels) {
        list.push_back({{"id", static_cast<std::uint32_t>(c.id)},
                        {"topic", c.topic},
                        {"encoding", "cdr"},
                        {"schemaName", c.schema_name},
                        {"schema", c.schema},
                        {"schemaEncoding", "ros2msg"}});
    }
    return Json{{"op", "advertise"}, {"channels", list}}.dump();
}

std::string foxglove_status(FoxgloveStatusLevel level, const std::string& message) {
    return Json{{"op", "status"}, {"level", static_cast<int>(level)}, {"message", message}}.dump();
}

FoxgloveRequest parse_foxglove_request(const std::string& text) {
    const Json message = Json::parse(text, nullptr, false);
    if (message.is_discarded() || !message.is_object()) return invalid("not a JSON object");
    const auto op = message.find("op");
    if (op == message.end() || !op->is_string()) return invalid("no \"op\"");
    if (*op == "subscribe") return parse_subscribe(message);
    if (*op == "unsubscribe") return parse_unsubscribe(message);
    return invalid("unsupported op \"" + op->get<std::string>() + "\"");
}

void foxglove_message_data(std::uint32_t subscription_id, std::uint64_t receive_ns,
                           const std::vector<std::uint8_t>& payload, std::string* frame) {
    frame->resize(kFoxgloveMessageDataHeaderBytes + payload.size());
    char* out = frame->data();
    out[0] = static_cast<char>(kFoxgloveMessageDataOpcode);
    put_le(subscription_id, 4, out + 1);
    put_le(receive_ns, 8, out + 5);
    std::copy(payload.begin(), payload.end(), out + kFoxgloveMessageDataHeaderBytes);
}

}  // namespace lidarfuse::daemon
