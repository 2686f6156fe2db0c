#pragma once
// Sends the simulated datagrams over UDP in real time (`lidarfuse sim --live --to HOST`):
// each datagram leaves when the wall clock has advanced as far past the first datagram as
// its capture time has, to HOST at the sensor's own lidar port. When rendering falls
// behind real time, datagrams go out at once and are counted as late.
// Not thread-safe; called from the simulator's run() thread.

#include <chrono>
#include <cstdint>
#include <string>

#include "drivers/net/udp_sender.hpp"
#include "drivers/sim/simulator.hpp"

namespace lidarfuse::sim {

class LiveSink : public DatagramSink {
public:
    // `host`: dotted quad or host name; throws std::invalid_argument / std::runtime_error.
    explicit LiveSink(const std::string& host);
    void write(const SimDatagram& d) override;

    std::uint64_t sent() const { return sent_; }
    std::uint64_t late() const { return late_; }      // sent more than 5 ms behind schedule
    std::uint64_t errors() const { return errors_; }  // send_to failures

private:
    net::UdpSender sender_;
    std::uint32_t host_ip_;
    bool started_ = false;
    std::int64_t first_capture_ns_ = 0;
    std::chrono::steady_clock::time_point wall0_;
    std::uint64_t sent_ = 0, late_ = 0, errors_ = 0;
};

}  // namespace lidarfuse::sim
