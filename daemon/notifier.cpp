#include "daemon/notifier.hpp"

#include <systemd/sd-daemon.h>

namespace seavio::daemon {

bool SystemdNotifier::notify(const std::string& msg) {
  // unset_environment=0: children (none today) and later calls keep NOTIFY_SOCKET.
  return sd_pid_notify(0, 0, msg.c_str()) > 0;
}

std::chrono::microseconds SystemdNotifier::watchdogPeriod() const {
  uint64_t usec = 0;
  // sd_watchdog_enabled checks WATCHDOG_PID against getpid() for us.
  if (sd_watchdog_enabled(0, &usec) > 0) return std::chrono::microseconds(usec);
  return {};
}

}  // namespace seavio::daemon
