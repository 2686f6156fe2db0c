#include "drivers/net/udp_receiver.hpp"

#include <arpa/inet.h>
#include <linux/sock_diag.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "drivers/net/ipv4_address.hpp"

namespace lidarfuse::net {

namespace {

constexpr std::size_t kMaxSockets = 63;  // plus the eventfd: poll()'s array lives on the stack

// Room for SCM_TIMESTAMPNS (struct timespec) and SO_RXQ_OVFL (uint32) control messages.
constexpr std::size_t kControlBytes =
    CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t)) + 64;

std::int64_t realtime_now_ns() {
    timespec ts{};
    clock_gettime(CLOCK_REALTIME, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void check_params(const UdpReceiverParams& params) {
    if (params.ports.empty()) throw std::runtime_error("UDP receiver: no ports configured");
    if (params.ports.size() > kMaxSockets) {
        throw std::runtime_error("UDP receiver: " + std::to_string(params.ports.size()) +
                                 " ports configured, at most 63 per receiver");
    }
    if (params.batch_size == 0 || params.max_datagram_bytes == 0) {
        throw std::runtime_error("UDP receiver: batch_size and max_datagram_bytes must be > 0");
    }
    if (params.coalesce_us < 0 || params.coalesce_us > 10'000'000) {
        throw std::runtime_error("UDP receiver: coalesce_us must be 0..10000000, not " +
                                 std::to_string(params.coalesce_us));
    }
}

// SO_RCVBUFFORCE when the process may, else SO_RCVBUF (capped by net.core.rmem_max); the
// size granted, read back.
void set_receive_buffer(int fd, int bytes, UdpSocketInfo* info) {
    if (::setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &bytes, sizeof bytes) == 0) {
        info->rcvbuf_forced = true;
    } else {
        ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
    }
    socklen_t len = sizeof info->granted_rcvbuf_bytes;
    ::getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &info->granted_rcvbuf_bytes, &len);
}

// A bound non-blocking socket with kernel timestamps and drop counts, or -1 with the
// problem appended to `problems`.
int open_socket(const UdpReceiverParams& params, std::uint32_t bind_ip, std::uint16_t port,
                UdpSocketInfo* info, std::string* problems) {
    const std::string where = params.bind_address + ":" + std::to_string(port);
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        *problems += "\n  " + where + ": socket: " + std::strerror(errno);
        return -1;
    }
    set_receive_buffer(fd, params.requested_rcvbuf_bytes, info);
    const int on = 1;
    if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0 ||
        ::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) != 0) {
        *problems += "\n  " + where + ": setsockopt: " + std::strerror(errno);
        ::close(fd);
        return -1;
    }
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(bind_ip);
    addr.sin_port = htons(port);
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
        *problems += "\n  " + where + ": bind: " + std::strerror(errno);
        ::close(fd);
        return -1;
    }
    socklen_t len = sizeof addr;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
    info->port = ntohs(addr.sin_port);
    return fd;
}

}  // namespace

// The preallocated ring: batch_size buffers of max_datagram_bytes, reused by every call.
// The buffers are left uninitialised: the kernel writes only a datagram's length into each
// 64 KiB slot (an OS1-64 packet is about 13 KB), so the pages past it are never touched and
// never resident; zero-filling them would cost 2 MiB of RSS per port.
struct UdpReceiver::Batch {
    Batch(std::size_t n, std::size_t max_datagram_bytes)
        : buffers(new std::uint8_t[n * max_datagram_bytes]),
          iov(n),
          msgs(n),
          sources(n),
          control(n * kControlBytes + alignof(cmsghdr)) {}

    std::unique_ptr<std::uint8_t[]> buffers;
    std::vector<iovec> iov;
    std::vector<mmsghdr> msgs;
    std::vector<sockaddr_in> sources;
    std::vector<std::uint8_t> control;  // kControlBytes per message, cmsghdr-aligned below
};

UdpReceiver::UdpReceiver(const UdpReceiverParams& params) : params_(params) {
    check_params(params_);
    const std::uint32_t bind_ip = parse_ipv4(params_.bind_address);
    std::string problems;
    for (const std::uint16_t port : params_.ports) {
        UdpSocketInfo info;
        const int fd = open_socket(params_, bind_ip, port, &info, &problems);
        if (fd < 0) continue;
        fds_.push_back(fd);
        sockets_.push_back(info);
    }
    wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (wake_fd_ < 0) problems += std::string("\n  eventfd: ") + std::strerror(errno);
    if (!problems.empty()) {
        for (const int fd : fds_) ::close(fd);
        if (wake_fd_ >= 0) ::close(wake_fd_);
        throw std::runtime_error("UDP receiver cannot open its sockets:" + problems);
    }
    last_drop_count_.assign(fds_.size(), 0);
    int smallest = sockets_.front().granted_rcvbuf_bytes;
    for (const auto& info : sockets_) smallest = std::min(smallest, info.granted_rcvbuf_bytes);
    wait_limit_bytes_ = static_cast<std::uint64_t>(std::max(smallest, 0)) / 4;
    batch_ = std::make_unique<Batch>(params_.batch_size, params_.max_datagram_bytes);
}

UdpReceiver::~UdpReceiver() {
    for (const int fd : fds_) ::close(fd);
    if (wake_fd_ >= 0) ::close(wake_fd_);
}

void UdpReceiver::stop() {
    stop_.store(true, std::memory_order_release);
    const std::uint64_t one = 1;
    // Async-signal-safe; a full counter (impossible in practice) still leaves it readable.
    [[maybe_unused]] const ssize_t written = ::write(wake_fd_, &one, sizeof one);
}

void UdpReceiver::run(const DatagramHandler& handler) {
    while (!stopped()) {
        const std::uint64_t bytes_before = stats_.bytes.load(std::memory_order_relaxed);
        if (poll_once(params_.poll_timeout_ms, handler) == 0 || params_.coalesce_us == 0) continue;
        if (stats_.bytes.load(std::memory_order_relaxed) - bytes_before >= wait_limit_bytes_) {
            stats_.waits_skipped.fetch_add(1, std::memory_order_relaxed);
            continue;
        }
        wait_to_coalesce();
    }
}

void UdpReceiver::wait_to_coalesce() {
    pollfd wake{wake_fd_, POLLIN, 0};
    const timespec wait{params_.coalesce_us / 1'000'000,
                        static_cast<long>(params_.coalesce_us % 1'000'000) * 1000};
    ::ppoll(&wake, 1, &wait, nullptr);  // EINTR or a stop(): the next poll_once tells
}

std::size_t UdpReceiver::poll_once(int timeout_ms, const DatagramHandler& handler) {
    if (stopped()) return 0;
    pollfd fds[kMaxSockets + 1];
    const std::size_t count = fds_.size();
    fds[0] = {wake_fd_, POLLIN, 0};
    for (std::size_t i = 0; i < count; ++i) fds[i + 1] = {fds_[i], POLLIN, 0};
    const int ready = ::poll(fds, static_cast<nfds_t>(count + 1), timeout_ms);
    if (ready < 0) {
        if (errno != EINTR) stats_.errors.fetch_add(1, std::memory_order_relaxed);
        return 0;
    }
    if (ready == 0) {
        // Idle: drops after the last delivered datagram have no later datagram to carry
        // them, so ask each socket for its count directly.
        for (std::size_t i = 0; i < count; ++i) read_drop_count(i);
        return 0;
    }
    if (stopped()) return 0;
    stats_.wakeups.fetch_add(1, std::memory_order_relaxed);
    std::size_t delivered = 0;
    for (std::size_t i = 0; i < count; ++i) {
        if (fds[i + 1].revents != 0) delivered += drain(i, handler);
    }
    return delivered;
}

void UdpReceiver::note_drop_count(std::size_t socket_index, std::uint32_t drops) {
    // The kernel's running count since the socket opened (the same counter through
    // SO_RXQ_OVFL and SO_MEMINFO); the unsigned difference survives wrap-around.
    const std::uint32_t delta = drops - last_drop_count_[socket_index];
    if (delta > 0 && delta < 0x80000000u) {
        stats_.kernel_drops.fetch_add(delta, std::memory_order_relaxed);
        last_drop_count_[socket_index] = drops;
    }
}

void UdpReceiver::read_drop_count(std::size_t socket_index) {
    std::uint32_t info[SK_MEMINFO_VARS] = {};
    socklen_t len = sizeof info;
    if (::getsockopt(fds_[socket_index], SOL_SOCKET, SO_MEMINFO, info, &len) == 0 &&
        len >= (SK_MEMINFO_DROPS + 1) * sizeof(std::uint32_t)) {
        note_drop_count(socket_index, info[SK_MEMINFO_DROPS]);
    }
}

std::size_t UdpReceiver::drain(std::size_t socket_index, const DatagramHandler& handler) {
    const std::size_t n = params_.batch_size;
    std::size_t delivered = 0;
    for (std::size_t round = 0; round < params_.max_batches_per_wakeup; ++round) {
        prepare_batch();
        const int got = ::recvmmsg(fds_[socket_index], batch_->msgs.data(),
                                   static_cast<unsigned>(n), MSG_DONTWAIT, nullptr);
        if (got < 0) {
            if (errno == EINTR) continue;
            if (errno != EAGAIN && errno != EWOULDBLOCK) {
                stats_.errors.fetch_add(1, std::memory_order_relaxed);
            }
            break;
        }
        stats_.batches.fetch_add(1, std::memory_order_relaxed);
        delivered += deliver(socket_index, static_cast<std::size_t>(got), handler);
        if (static_cast<std::size_t>(got) < n) break;  // socket drained
    }
    stats_.datagrams.fetch_add(delivered, std::memory_order_relaxed);
    return delivered;
}

void UdpReceiver::prepare_batch() {
    Batch& b = *batch_;
    auto* control_base = reinterpret_cast<std::uint8_t*>(
        (reinterpret_cast<std::uintptr_t>(b.control.data()) + alignof(cmsghdr) - 1) &
        ~(static_cast<std::uintptr_t>(alignof(cmsghdr)) - 1));
    for (std::size_t k = 0; k < params_.batch_size; ++k) {
        b.iov[k] = {&b.buffers[k * params_.max_datagram_bytes], params_.max_datagram_bytes};
        msghdr& h = b.msgs[k].msg_hdr;
        h.msg_name = &b.sources[k];
        h.msg_namelen = sizeof(sockaddr_in);
        h.msg_iov = &b.iov[k];
        h.msg_iovlen = 1;
        h.msg_control = control_base + k * kControlBytes;
        h.msg_controllen = kControlBytes;
        h.msg_flags = 0;
        b.msgs[k].msg_len = 0;
    }
}

std::size_t UdpReceiver::deliver(std::size_t socket_index, std::size_t got,
                                 const DatagramHandler& handler) {
    Batch& b = *batch_;
    const std::int64_t fallback_time_ns = realtime_now_ns();
    std::uint64_t bytes = 0;
    std::size_t delivered = 0;
    for (std::size_t k = 0; k < got; ++k) {
        msghdr& h = b.msgs[k].msg_hdr;
        ReceivedDatagram d;
        d.receive_time_ns = fallback_time_ns;
        read_control(socket_index, &h, &d);
        if (h.msg_flags & MSG_TRUNC) {
            stats_.truncated.fetch_add(1, std::memory_order_relaxed);
            continue;
        }
        d.socket_index = socket_index;
        d.local_port = sockets_[socket_index].port;
        d.src_ip = ntohl(b.sources[k].sin_addr.s_addr);
        d.src_port = ntohs(b.sources[k].sin_port);
        d.data = static_cast<const std::uint8_t*>(b.iov[k].iov_base);
        d.size = b.msgs[k].msg_len;
        handler(d);
        bytes += d.size;
        ++delivered;
    }
    stats_.bytes.fetch_add(bytes, std::memory_order_relaxed);
    return delivered;
}

void UdpReceiver::read_control(std::size_t socket_index, msghdr* h, ReceivedDatagram* d) {
    for (cmsghdr* c = CMSG_FIRSTHDR(h); c; c = CMSG_NXTHDR(h, c)) {
        if (c->cmsg_level != SOL_SOCKET) continue;
        if (c->cmsg_type == SCM_TIMESTAMPNS) {
            timespec ts;
            std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
            d->receive_time_ns = static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
        } else if (c->cmsg_type == SO_RXQ_OVFL) {
            std::uint32_t drops;
            std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
            note_drop_count(socket_index, drops);
        }
    }
}

}  // namespace lidarfuse::net
