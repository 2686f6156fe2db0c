#include "drivers/sim/live_sink.hpp"

#include <thread>

#include "drivers/net/ipv4_address.hpp"

namespace lidarfuse::sim {

LiveSink::LiveSink(const std::string& host) : host_ip_(net::resolve_ipv4(host)) {}

void LiveSink::write(const SimDatagram& d) {
    if (!started_) {
        started_ = true;
        first_capture_ns_ = d.capture_ns;
        wall0_ = std::chrono::steady_clock::now();
    }
    const auto due = wall0_ + std::chrono::nanoseconds(d.capture_ns - first_capture_ns_);
    const auto now = std::chrono::steady_clock::now();
    if (now < due) {
        std::this_thread::sleep_until(due);
    } else if (now - due > std::chrono::milliseconds(5)) {
        ++late_;
    }
    if (sender_.send_to(host_ip_, d.dst_port, d.payload.data(), d.payload.size())) {
        ++sent_;
    } else {
        ++errors_;
    }
}

}  // namespace lidarfuse::sim
