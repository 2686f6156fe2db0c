#include "daemon/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdint>
#include <cstdlib>

namespace lidarfuse::daemon {

namespace {
// STATUS= is one line: a newline would end the assignment early.
std::string one_line(std::string text) {
    for (auto& c : text) {
        if (c == '\n' || c == '\r') c = ' ';
    }
    return text;
}
}  // namespace

SystemdNotifier::SystemdNotifier() {
    const char* socket = std::getenv("NOTIFY_SOCKET");
    enabled_ = socket != nullptr && *socket != '\0';
    std::uint64_t usec = 0;
    if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) {
        watchdog_period_ = std::chrono::microseconds(usec / 2);
    }
}

bool SystemdNotifier::send(const std::string& message) const {
    return enabled_ && sd_notify(0, message.c_str()) > 0;
}

bool SystemdNotifier::ready(const std::string& status) const {
    return send("READY=1\nSTATUS=" + one_line(status));
}

bool SystemdNotifier::watchdog() const { return send("WATCHDOG=1"); }

bool SystemdNotifier::status(const std::string& status) const {
    return send("STATUS=" + one_line(status));
}

bool SystemdNotifier::stopping() const { return send("STOPPING=1"); }

}  // namespace lidarfuse::daemon
