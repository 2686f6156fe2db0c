#include "drivers/net/ipv4_address.hpp"

#include <arpa/inet.h>
#include <netdb.h>
#include <sys/socket.h>

#include <cstring>
#include <stdexcept>

namespace lidarfuse::net {

std::uint32_t parse_ipv4(const std::string& text) {
    in_addr addr{};
    if (inet_pton(AF_INET, text.c_str(), &addr) != 1) {
        throw std::invalid_argument("'" + text + "' is not an IPv4 address (a.b.c.d)");
    }
    return ntohl(addr.s_addr);
}

std::uint32_t resolve_ipv4(const std::string& host) {
    in_addr addr{};
    if (inet_pton(AF_INET, host.c_str(), &addr) == 1) return ntohl(addr.s_addr);
    addrinfo hints{};
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_DGRAM;
    addrinfo* result = nullptr;
    const int rc = getaddrinfo(host.c_str(), nullptr, &hints, &result);
    if (rc != 0 || !result) {
        throw std::invalid_argument("cannot resolve host '" + host +
                                    "' to an IPv4 address: " + gai_strerror(rc));
    }
    sockaddr_in sin{};
    std::memcpy(&sin, result->ai_addr, sizeof sin);
    freeaddrinfo(result);
    return ntohl(sin.sin_addr.s_addr);
}

std::string ipv4_to_string(std::uint32_t ip) {
    return std::to_string(ip >> 24) + "." + std::to_string((ip >> 16) & 0xFF) + "." +
           std::to_string((ip >> 8) & 0xFF) + "." + std::to_string(ip & 0xFF);
}

}  // namespace lidarfuse::net
