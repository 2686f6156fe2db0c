#pragma once
// A plain IPv4 UDP sending socket (blocking), used by replay, tests and benchmarks.

#include <cstddef>
#include <cstdint>
#include <string>

namespace lidarfuse::net {

struct UdpSenderParams {
    std::string bind_address = "0.0.0.0";  // source address; 0.0.0.0 = chosen by the kernel
    std::uint16_t bind_port = 0;           // 0 = ephemeral
    int requested_sndbuf_bytes = 4 * 1024 * 1024;
};

class UdpSender {
public:
    // Throws std::runtime_error naming the address/port when the socket cannot be set up.
    explicit UdpSender(const UdpSenderParams& params = {});
    ~UdpSender();
    UdpSender(const UdpSender&) = delete;
    UdpSender& operator=(const UdpSender&) = delete;

    // Sends one datagram (addresses in host order). False on error, with errno in
    // last_errno(); never throws (used on paced send loops).
    bool send_to(std::uint32_t dst_ip, std::uint16_t dst_port, const std::uint8_t* data,
                 std::size_t size);

    std::uint16_t local_port() const { return local_port_; }
    int last_errno() const { return last_errno_; }

private:
    int fd_ = -1;
    std::uint16_t local_port_ = 0;
    int last_errno_ = 0;
};

}  // namespace lidarfuse::net
