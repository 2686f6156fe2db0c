#include "drivers/sim/live_sink.hpp"

#include <thread>

namespace lidarfuse::sim {

LiveRoutes::LiveRoutes(const Simulator& simulator, std::uint32_t ip) {
    for (const auto& rig : simulator.rigs()) {
        Route r;
        r.ip = ip;
        r.port = rig.info().udp_port_lidar;
        routes_.push_back(r);
    }
}

LiveRoutes::Route LiveRoutes::get(int sensor) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return routes_.at(static_cast<std::size_t>(sensor));
}

void LiveRoutes::set(int sensor, const Route& route) {
    std::lock_guard<std::mutex> lock(mutex_);
    routes_.at(static_cast<std::size_t>(sensor)) = route;
}

std::size_t LiveRoutes::size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return routes_.size();
}

LiveSink::LiveSink(LiveRoutes* routes) : routes_(routes) {}

void LiveSink::write(const SimDatagram& d) {
    if (!started_) {
        started_ = true;
        first_capture_ns_ = d.capture_ns;
        wall0_ = std::chrono::steady_clock::now();
    }
    const auto due = wall0_ + std::chrono::nanoseconds(d.capture_ns - first_capture_ns_);
    auto now = std::chrono::steady_clock::now();
    if (now < due) {
        std::this_thread::sleep_until(due);
        now = std::chrono::steady_clock::now();
    } else if (now - due > std::chrono::milliseconds(5)) {
        ++late_;
    }
    routes_->note_sent(d.capture_ns);
    const LiveRoutes::Route route = routes_->get(d.sensor);
    if (route.standby || now.time_since_epoch().count() < route.resume_steady_ns) {
        ++held_back_;
        return;
    }
    if (sender_.send_to(route.ip, route.port, d.payload.data(), d.payload.size())) {
        ++sent_;
    } else {
        ++errors_;
    }
}

}  // namespace lidarfuse::sim
