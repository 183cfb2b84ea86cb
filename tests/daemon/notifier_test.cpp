// sd_notify through libsystemd to a listener on a temporary NOTIFY_SOCKET.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <string>

#include "daemon/notifier.hpp"
#include "tests/daemon/notify_listener.hpp"

namespace seavio::daemon {
namespace notifier_test {
namespace {

/// The listener on a temporary NOTIFY_SOCKET, exported for libsystemd's sd_notify.
class NotifySocket : public test::NotifyListener {
 public:
  NotifySocket() { exportNotifySocket(); }
  /// Next datagram, empty after 1 s.
  std::string receive() { return next(std::chrono::seconds(1)); }
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
}  // namespace notifier_test
}  // namespace seavio::daemon
