#include "drivers/net/udp_sender.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "drivers/net/ipv4_address.hpp"

namespace lidarfuse::net {

UdpSender::UdpSender(const UdpSenderParams& params) {
    const std::uint32_t bind_ip = parse_ipv4(params.bind_address);
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0)
        throw std::runtime_error(std::string("cannot create UDP socket: ") + std::strerror(errno));
    const int sndbuf = params.requested_sndbuf_bytes;
    if (::setsockopt(fd_, SOL_SOCKET, SO_SNDBUFFORCE, &sndbuf, sizeof sndbuf) != 0) {
        ::setsockopt(fd_, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof sndbuf);  // capped by wmem_max
    }
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(bind_ip);
    addr.sin_port = htons(params.bind_port);
    if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
        const int err = errno;
        ::close(fd_);
        throw std::runtime_error("cannot bind UDP sender to " + params.bind_address + ":" +
                                 std::to_string(params.bind_port) + ": " + std::strerror(err));
    }
    socklen_t len = sizeof addr;
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    local_port_ = ntohs(addr.sin_port);
}

UdpSender::~UdpSender() {
    if (fd_ >= 0) ::close(fd_);
}

bool UdpSender::send_to(std::uint32_t dst_ip, std::uint16_t dst_port, const std::uint8_t* data,
                        std::size_t size) {
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(dst_ip);
    addr.sin_port = htons(dst_port);
    for (;;) {
        const ssize_t sent =
            ::sendto(fd_, data, size, 0, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
        if (sent == static_cast<ssize_t>(size)) return true;
        if (sent < 0 && errno == EINTR) continue;
        last_errno_ = sent < 0 ? errno : EMSGSIZE;
        return false;
    }
}

}  // namespace lidarfuse::net
