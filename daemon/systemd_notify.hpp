#pragma once
// The systemd notify protocol (Type=notify): READY=1 once the config is valid and sockets
// are bound, WATCHDOG=1 from the pipeline heartbeat, STATUS= for `systemctl status`,
// STOPPING=1 on shutdown. Outside systemd (no NOTIFY_SOCKET) every call is a no-op that
// returns false. Thread-safe: sd_notify opens its own socket per call.

#include <chrono>
#include <optional>
#include <string>

namespace lidarfuse::daemon {

class SystemdNotifier {
public:
    SystemdNotifier();

    bool enabled() const { return enabled_; }
    // Half of WatchdogSec when the unit enables the watchdog for this process.
    std::optional<std::chrono::microseconds> watchdog_period() const { return watchdog_period_; }

    bool ready(const std::string& status) const;
    bool watchdog() const;
    bool status(const std::string& status) const;
    bool stopping() const;

private:
    bool send(const std::string& message) const;

    bool enabled_ = false;
    std::optional<std::chrono::microseconds> watchdog_period_;
};

}  // namespace lidarfuse::daemon
