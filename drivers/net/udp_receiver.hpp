#pragma once
// Receives UDP/IPv4 datagrams from one or more ports with recvmmsg batching into a
// preallocated ring of buffers and hands each one to a callback on the receiving thread.
//
// Per socket: non-blocking, a large receive buffer (SO_RCVBUFFORCE when the process may,
// else SO_RCVBUF capped by net.core.rmem_max; the granted size is read back), kernel
// receive timestamps (SO_TIMESTAMPNS: CLOCK_REALTIME, ns since the Unix epoch, taken when
// the packet reached the socket layer), and the kernel's drop counter (packets dropped
// because the receive buffer was full: SO_RXQ_OVFL, and SO_MEMINFO when idle). Each datagram
// carries its source address, so several sensors sharing a port can be told apart.
//
// Threading: poll_once()/run() on one thread; stop() and stats() from any thread. stop() is
// async-signal-safe (an atomic store and a write to an eventfd), and wakes a blocked poll at
// once. The callback runs on the receiving thread and must be cheap: copy the bytes into a
// ring and return; it must never wait on later pipeline stages. The data pointer is valid
// only during the callback. No allocation or exception after construction.

#include <sys/types.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

struct msghdr;  // <sys/socket.h>

namespace lidarfuse::net {

struct UdpReceiverParams {
    std::string bind_address = "0.0.0.0";    // IPv4 address to bind every port to
    std::vector<std::uint16_t> ports;        // one socket each; 0 = ephemeral (see sockets())
    std::size_t batch_size = 32;             // datagrams per recvmmsg call
    std::size_t max_datagram_bytes = 65536;  // per buffer; longer datagrams are truncated
    int requested_rcvbuf_bytes = 32 * 1024 * 1024;
    int poll_timeout_ms = 100;  // run(): how long one poll may sleep when nothing arrives
    // run(): after a wake-up that delivered datagrams, how long (microseconds) to wait
    // before polling again, so that what arrives meanwhile is read in one batch (user-space
    // interrupt coalescing). A sensor sends a datagram every 0.8 ms, and each wake-up (a
    // poll, a recvmmsg, two context switches) costs several times the decoding of the
    // datagram: a wait of a few milliseconds trades that much latency for a fraction of the
    // wake-ups. Kernel timestamps keep each datagram's arrival time exact. 0..10 s; 0: poll
    // again at once. stop() ends the wait at once. A wake-up that read a quarter of the
    // smallest granted receive buffer or more is not followed by a wait: the socket fills
    // fast enough that waiting could overflow it (high-rate sensors, several on one port,
    // a small buffer).
    int coalesce_us = 0;
    std::size_t max_batches_per_wakeup = 16;  // per socket, so one busy port cannot starve others
};

struct ReceivedDatagram {
    std::size_t socket_index = 0;  // index into UdpReceiverParams::ports
    std::uint16_t local_port = 0;
    std::uint32_t src_ip = 0;  // host byte order
    std::uint16_t src_port = 0;
    std::int64_t receive_time_ns = 0;  // CLOCK_REALTIME (kernel timestamp; see above)
    const std::uint8_t* data = nullptr;
    std::size_t size = 0;
};

// Counters over all sockets; relaxed atomics, readable from any thread while running.
struct UdpReceiverStats {
    std::atomic<std::uint64_t> datagrams{0};  // delivered to the callback
    std::atomic<std::uint64_t> bytes{0};      // payload bytes delivered
    std::atomic<std::uint64_t> truncated{0};  // longer than max_datagram_bytes: counted, dropped
    // Dropped by the kernel for a full receive buffer. The kernel reports its running count
    // with the next datagram it delivers (SO_RXQ_OVFL); drops after the last datagram are
    // read with SO_MEMINFO when a poll times out, so they show within poll_timeout_ms.
    std::atomic<std::uint64_t> kernel_drops{0};
    std::atomic<std::uint64_t> errors{0};   // failed recvmmsg/poll calls (EINTR excepted)
    std::atomic<std::uint64_t> batches{0};  // recvmmsg calls that returned data
    std::atomic<std::uint64_t> wakeups{0};  // polls that returned with work
    // run(): wake-ups not followed by the wait (UdpReceiverParams::coalesce_us), as they
    // read a quarter of the receive buffer or more.
    std::atomic<std::uint64_t> waits_skipped{0};
};

struct UdpSocketInfo {
    std::uint16_t port = 0;        // bound port (resolved when 0 was asked)
    int granted_rcvbuf_bytes = 0;  // SO_RCVBUF read back (the kernel doubles requests)
    bool rcvbuf_forced = false;    // SO_RCVBUFFORCE worked (CAP_NET_ADMIN)
};

using DatagramHandler = std::function<void(const ReceivedDatagram&)>;

class UdpReceiver {
public:
    // Opens and binds every port; throws std::runtime_error listing every port that failed.
    explicit UdpReceiver(const UdpReceiverParams& params);
    ~UdpReceiver();
    UdpReceiver(const UdpReceiver&) = delete;
    UdpReceiver& operator=(const UdpReceiver&) = delete;

    // Waits up to `timeout_ms` (-1 = forever) for data or stop(), then drains the ready
    // sockets. Returns the number of datagrams delivered. Returns 0 at once after stop().
    std::size_t poll_once(int timeout_ms, const DatagramHandler& handler);

    // poll_once(params.poll_timeout_ms) until stop().
    void run(const DatagramHandler& handler);

    void stop();
    bool stopped() const { return stop_.load(std::memory_order_acquire); }

    const std::vector<UdpSocketInfo>& sockets() const { return sockets_; }
    const UdpReceiverParams& params() const { return params_; }
    const UdpReceiverStats& stats() const { return stats_; }

private:
    struct Batch;
    std::size_t drain(std::size_t socket_index, const DatagramHandler& handler);
    // run()'s wait of params_.coalesce_us, on the eventfd alone: stop() ends it.
    void wait_to_coalesce();
    // drain's steps: every message header of the ring pointed at its buffers again; the
    // `got` datagrams recvmmsg filled handed to the handler (how many, truncated ones
    // skipped); one datagram's kernel timestamp and drop count.
    void prepare_batch();
    std::size_t deliver(std::size_t socket_index, std::size_t got, const DatagramHandler& handler);
    inline void read_control(std::size_t socket_index, msghdr* h, ReceivedDatagram* d);
    void note_drop_count(std::size_t socket_index, std::uint32_t drops);
    void read_drop_count(std::size_t socket_index);

    UdpReceiverParams params_;
    std::vector<int> fds_;
    std::vector<UdpSocketInfo> sockets_;
    std::vector<std::uint32_t> last_drop_count_;  // kernel drop count seen last, per socket
    std::uint64_t wait_limit_bytes_ = 0;          // a quarter of the smallest granted buffer
    int wake_fd_ = -1;                            // eventfd written by stop()
    std::unique_ptr<Batch> batch_;
    std::atomic<bool> stop_{false};
    UdpReceiverStats stats_;
};

}  // namespace lidarfuse::net
