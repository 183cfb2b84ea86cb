#include "daemon/timestamp_monitor.hpp"

#include "core/common/saturating.hpp"

namespace seavio::daemon {

StampCheck TimestampMonitor::check(int64_t t_ns) {
  if (!have_) {
    have_ = true;
    last_ = t_ns;
    return StampCheck::kFirst;
  }
  if (t_ns == last_) return StampCheck::kDuplicate;
  if (t_ns < last_) {
    run_ = (run_ > 0 && t_ns > run_last_) ? run_ + 1 : 1;
    run_last_ = t_ns;
    if (run_ < restart_after_) return StampCheck::kOutOfOrder;
    run_ = 0;
    last_ = t_ns;
    return StampCheck::kRestart;
  }
  run_ = 0;
  const int64_t dt = saturatingSub(t_ns, last_);  // stamps from outside: any int64
  last_ = t_ns;
  return dt > max_gap_ns_ ? StampCheck::kGap : StampCheck::kOk;
}

}  // namespace seavio::daemon
