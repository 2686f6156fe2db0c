#pragma once
// IPv4 address text <-> host-byte-order integers, shared by the receiver, sender and replay.

#include <cstdint>
#include <string>

namespace lidarfuse::net {

// "169.254.92.158" -> 0xA9FE5C9E. Throws std::invalid_argument naming the text.
std::uint32_t parse_ipv4(const std::string& text);

// Dotted quad, or a host name resolved to its first IPv4 address ("localhost").
// Throws std::invalid_argument naming the host when it does not resolve.
std::uint32_t resolve_ipv4(const std::string& host);

std::string ipv4_to_string(std::uint32_t ip);

constexpr std::uint32_t kLoopbackIpv4 = 0x7F000001u;  // 127.0.0.1

}  // namespace lidarfuse::net
