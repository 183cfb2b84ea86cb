// sd_notify through libsystemd to a listener on a temporary NOTIFY_SOCKET.
#include <gtest/gtest.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "daemon/notifier.hpp"

namespace seavio::daemon {
namespace {

class NotifySocket {
 public:
  NotifySocket() {
    path_ = (std::filesystem::temp_directory_path() / ("seavio_notify_" + std::to_string(getpid()))).string();
    std::filesystem::remove(path_);
    fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::snprintf(a.sun_path, sizeof a.sun_path, "%s", path_.c_str());
    ok_ = fd_ >= 0 && bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    timeval tv{1, 0};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    setenv("NOTIFY_SOCKET", path_.c_str(), 1);
  }
  ~NotifySocket() {
    unsetenv("NOTIFY_SOCKET");
    unsetenv("WATCHDOG_USEC");
    unsetenv("WATCHDOG_PID");
    if (fd_ >= 0) close(fd_);
    std::filesystem::remove(path_);
  }
  bool ok() const { return ok_; }
  /// Next datagram, empty after 1 s.
  std::string receive() {
    char buf[4096];
    const ssize_t n = recv(fd_, buf, sizeof buf, 0);
    return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
  }

 private:
  std::string path_;
  int fd_ = -1;
  bool ok_ = false;
};

TEST(SystemdNotifier, MessagesReachTheNotifySocket) {
  NotifySocket sock;
  ASSERT_TRUE(sock.ok());
  SystemdNotifier n;
  EXPECT_TRUE(n.notify("READY=1\nSTATUS=first pose published"));
  EXPECT_EQ(sock.receive(), "READY=1\nSTATUS=first pose published");
  EXPECT_TRUE(n.notify("WATCHDOG=1"));
  EXPECT_EQ(sock.receive(), "WATCHDOG=1");
}

TEST(SystemdNotifier, WatchdogHonouredOnlyForOurPid) {
  NotifySocket sock;
  SystemdNotifier n;
  setenv("WATCHDOG_USEC", "400000", 1);
  setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  EXPECT_EQ(n.watchdogPeriod(), std::chrono::microseconds(400000));
  setenv("WATCHDOG_PID", std::to_string(getpid() + 1).c_str(), 1);
  EXPECT_EQ(n.watchdogPeriod(), std::chrono::microseconds(0));
  unsetenv("WATCHDOG_PID");
  EXPECT_EQ(n.watchdogPeriod(), std::chrono::microseconds(400000));
  unsetenv("WATCHDOG_USEC");
  EXPECT_EQ(n.watchdogPeriod(), std::chrono::microseconds(0));
}

TEST(SystemdNotifier, WithoutNotifySocketNothingIsSent) {
  unsetenv("NOTIFY_SOCKET");
  SystemdNotifier n;
  EXPECT_FALSE(n.notify("READY=1"));
  NullNotifier null;
  EXPECT_FALSE(null.notify("READY=1"));
  EXPECT_EQ(null.watchdogPeriod().count(), 0);
}

}  // namespace
}  // namespace seavio::daemon
