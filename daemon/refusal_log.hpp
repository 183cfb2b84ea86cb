#pragma once
/// The log line of a frame whose visual estimate was refused: the check, what it measured and
/// the limit it missed. Rate-limited by frame time: one line per second of frames for the
/// same check, the count of those left out carried by the next line; a change of check is
/// logged at once. Header-only, as OdometryProcessor that owns it.
#include <cstdint>

#include <spdlog/spdlog.h>

#include "core/common/types.hpp"

namespace seavio::daemon {

class RefusalLog {
 public:
  explicit RefusalLog(int64_t period_ns = 1'000'000'000) : period_ns_(period_ns) {}

  /// Logs `r`'s refusal if it is one and the rate allows; returns true when it logged.
  bool add(const OdometryResult& r) {
    const Refusal check = r.refusal.check;
    if (check == Refusal::kNone) return false;
    if (logged_once_ && check == last_check_ && r.t_ns - last_t_ns_ < period_ns_) {
      ++left_out_;
      return false;
    }
    spdlog::warn("frame {}: vision refused by {} ({:.4g} against the limit {:.4g}; governed by {}){}", r.seq,
                 refusalName(check), r.refusal.value, r.refusal.limit, refusalConfigKey(check),
                 left_out_ > 0 ? fmt::format(", {} more refused frames since the last message", left_out_) : "");
    logged_once_ = true;
    last_check_ = check;
    last_t_ns_ = r.t_ns;
    left_out_ = 0;
    return true;
  }

 private:
  int64_t period_ns_;
  bool logged_once_ = false;
  Refusal last_check_ = Refusal::kNone;
  int64_t last_t_ns_ = 0;
  uint64_t left_out_ = 0;
};

}  // namespace seavio::daemon
