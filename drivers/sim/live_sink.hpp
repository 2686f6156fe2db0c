#pragma once
// Sends the simulated datagrams over UDP in real time (`lidarfuse sim --live --to HOST`):
// each datagram leaves when the wall clock has advanced as far past the first datagram as
// its capture time has, to HOST at the sensor's own lidar port (or where the sensor's HTTP
// API was told to send). When rendering falls
// behind real time, datagrams go out at once and are counted as late.
// Not thread-safe; called from the simulator's run() thread.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "drivers/net/udp_sender.hpp"
#include "drivers/sim/simulator.hpp"

namespace lidarfuse::sim {

// Where each simulated sensor sends and whether it sends now. Starts as --to says (sensor k
// to its own lidar port); the sensor's HTTP API (sim_http_server.hpp) changes it the way a
// POST to /api/v1/sensor/config changes a real sensor. Thread safe: the sending thread
// reads it, the HTTP server's threads write it.
class LiveRoutes {
public:
    struct Route {
        std::uint32_t ip = 0;  // IPv4, host byte order
        std::uint16_t port = 0;
        bool standby = false;               // operating_mode STANDBY: sends nothing
        std::int64_t resume_steady_ns = 0;  // re-initialising until then: sends nothing
    };

    LiveRoutes(const Simulator& simulator, std::uint32_t ip);
    Route get(int sensor) const;
    void set(int sensor, const Route& route);
    std::size_t size() const;

    // Capture time (ns) of the last datagram sent: the simulated "now" of the HTTP API.
    void note_sent(std::int64_t capture_ns) { last_capture_ns_.store(capture_ns); }
    std::int64_t last_capture_ns() const { return last_capture_ns_.load(); }

private:
    mutable std::mutex mutex_;
    std::vector<Route> routes_;
    std::atomic<std::int64_t> last_capture_ns_{kEpochNs};
};

class LiveSink : public DatagramSink {
public:
    // Sends as `routes` says at the moment each datagram is due.
    explicit LiveSink(LiveRoutes* routes);
    void write(const SimDatagram& d) override;

    std::uint64_t sent() const { return sent_; }
    std::uint64_t late() const { return late_; }            // sent more than 5 ms behind schedule
    std::uint64_t errors() const { return errors_; }        // send_to failures
    std::uint64_t held_back() const { return held_back_; }  // not sent: standby or re-initialising

private:
    net::UdpSender sender_;
    LiveRoutes* routes_;
    bool started_ = false;
    std::int64_t first_capture_ns_ = 0;
    std::chrono::steady_clock::time_point wall0_;
    std::uint64_t sent_ = 0, late_ = 0, errors_ = 0, held_back_ = 0;
};

}  // namespace lidarfuse::sim
