#pragma once
/// Service-manager notifications (sd_notify protocol): READY=1, WATCHDOG=1, STATUS=.
#include <chrono>
#include <cstdint>
#include <string>

namespace seavio::daemon {

class Notifier {
 public:
  virtual ~Notifier() = default;
  /// Sends one newline-separated sd_notify message; false if it could not be sent (or
  /// there is no service manager).
  virtual bool notify(const std::string& msg) = 0;
  /// Watchdog period requested by the service manager (WATCHDOG_USEC, honoured only if
  /// WATCHDOG_PID is unset or ours); zero when the watchdog is off.
  virtual std::chrono::microseconds watchdogPeriod() const = 0;
};

/// libsystemd's sd_pid_notify / sd_watchdog_enabled; a no-op without NOTIFY_SOCKET.
class SystemdNotifier : public Notifier {
 public:
  bool notify(const std::string& msg) override;
  std::chrono::microseconds watchdogPeriod() const override;
};

/// Discards everything (tests, `--no-notify`).
class NullNotifier : public Notifier {
 public:
  bool notify(const std::string&) override { return false; }
  std::chrono::microseconds watchdogPeriod() const override { return {}; }
};

}  // namespace seavio::daemon
