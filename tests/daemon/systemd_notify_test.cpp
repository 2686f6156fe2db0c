#include "daemon/systemd_notify.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <string>

#include "tests/support/test_data.hpp"

namespace lidarfuse::daemon {
namespace {

// A datagram socket standing in for systemd's notify socket.
class NotifySocket {
public:
    explicit NotifySocket(const std::string& path) : path_(path) {
        fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
        if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
            ADD_FAILURE() << "bind " << path << ": " << std::strerror(errno);
        }
        timeval tv{5, 0};
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
    }
    ~NotifySocket() { ::close(fd_); }
    std::string receive() {
        char buffer[4096];
        const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
        return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
    }

private:
    std::string path_;
    int fd_ = -1;
};

class ScopedEnv {
public:
    ScopedEnv(const char* name, const std::string& value) : name_(name) {
        ::setenv(name, value.c_str(), 1);
    }
    ~ScopedEnv() { ::unsetenv(name_); }

private:
    const char* name_;
};

TEST(SystemdNotifier, SpeaksTheNotifyProtocol) {
    test::TempDir dir("notify");
    const auto path = (dir.path() / "notify.sock").string();
    NotifySocket socket(path);
    ScopedEnv env("NOTIFY_SOCKET", path);
    ScopedEnv watchdog_usec("WATCHDOG_USEC", "4000000");
    ScopedEnv watchdog_pid("WATCHDOG_PID", std::to_string(::getpid()));

    SystemdNotifier notifier;
    ASSERT_TRUE(notifier.enabled());
    ASSERT_TRUE(notifier.watchdog_period().has_value());
    EXPECT_EQ(notifier.watchdog_period()->count(), 2000000);

    EXPECT_TRUE(notifier.ready("4 sensors\nbound"));
    EXPECT_EQ(socket.receive(), "READY=1\nSTATUS=4 sensors bound");
    EXPECT_TRUE(notifier.watchdog());
    EXPECT_EQ(socket.receive(), "WATCHDOG=1");
    EXPECT_TRUE(notifier.status("fused 10 frames"));
    EXPECT_EQ(socket.receive(), "STATUS=fused 10 frames");
    EXPECT_TRUE(notifier.stopping());
    EXPECT_EQ(socket.receive(), "STOPPING=1");
}

TEST(SystemdNotifier, OutsideSystemdEverythingIsANoOp) {
    ::unsetenv("NOTIFY_SOCKET");
    ::unsetenv("WATCHDOG_USEC");
    SystemdNotifier notifier;
    EXPECT_FALSE(notifier.enabled());
    EXPECT_FALSE(notifier.watchdog_period().has_value());
    EXPECT_FALSE(notifier.ready("x"));
    EXPECT_FALSE(notifier.watchdog());
}

}  // namespace
}  // namespace lidarfuse::daemon
