#pragma once
/// When a lost device is tried again: soon after the loss (a cable glitch heals in a
/// moment), then at doubling intervals up to a ceiling (a dead device is not hammered with
/// open() calls on the real-time thread), and soon again after any success. Shared by the
/// V4L2, libcamera and CAN drivers; times on the monotonic clock [ns].
#include <algorithm>
#include <cstdint>

namespace seavio::drivers {

struct ReconnectBackoffConfig {
  int first_ms = 100;  ///< delay before the first attempt after a loss [ms]
  int max_ms = 5000;   ///< ceiling of the doubling delay [ms]
};

class ReconnectBackoff {
 public:
  explicit ReconnectBackoff(ReconnectBackoffConfig cfg = {}) : cfg_(cfg), delay_ms_(std::max(cfg.first_ms, 1)) {}

  /// The device was lost or an attempt failed at `now_ns`: the next attempt waits the
  /// current delay, which then doubles (up to max_ms).
  void failed(int64_t now_ns) {
    next_ns_ = now_ns + int64_t{delay_ms_} * 1'000'000;
    delay_ms_ = std::min(std::max(delay_ms_, 1) * 2, std::max(cfg_.max_ms, cfg_.first_ms));
  }
  /// An attempt succeeded: the next loss is retried after first_ms again.
  void succeeded() { delay_ms_ = std::max(cfg_.first_ms, 1); }
  /// True when an attempt may be made at `now_ns`.
  bool due(int64_t now_ns) const { return now_ns >= next_ns_; }
  /// Time left until the next attempt [ns], 0 if due.
  int64_t waitNs(int64_t now_ns) const { return std::max<int64_t>(0, next_ns_ - now_ns); }
  /// The delay the next failure will wait [ms].
  int nextDelayMs() const { return delay_ms_; }

 private:
  ReconnectBackoffConfig cfg_;
  int delay_ms_;
  int64_t next_ns_ = 0;
};

}  // namespace seavio::drivers
