#pragma once
/// Classifies each new timestamp of a stream against the previous accepted one, so the
/// daemon counts out-of-order, duplicate and jumping timestamps instead of
/// feeding them to the estimator.
#include <cstdint>

namespace seavio::daemon {

enum class StampCheck {
  kOk,          ///< strictly increasing, within the gap limit
  kFirst,       ///< first sample of the stream
  kDuplicate,   ///< equal to the previous one: reject
  kOutOfOrder,  ///< earlier than the previous one: reject
  kGap,         ///< later than previous + max_gap_ns: accept, but count a gap
  kRestart,     ///< the last of a run of out-of-order stamps, each later than the one before
                ///< it: the source's clock went back for good (or the reference was a lone
                ///< stamp far ahead); accepted as the new reference
};

class TimestampMonitor {
 public:
  /// @param max_gap_ns a step larger than this counts as a gap [ns]
  /// @param restart_after this many consecutive increasing out-of-order stamps re-anchor the
  ///        stream (kRestart), so one stamp an hour ahead or a device clock reset costs a few
  ///        samples instead of rejecting every later one
  explicit TimestampMonitor(int64_t max_gap_ns, int restart_after = 3)
      : max_gap_ns_(max_gap_ns), restart_after_(restart_after) {}
  /// Checks `t_ns` and, unless rejected, makes it the new reference.
  StampCheck check(int64_t t_ns);
  int64_t last() const { return last_; }

 private:
  int64_t max_gap_ns_;
  int restart_after_;
  int64_t last_ = 0;
  bool have_ = false;
  int run_ = 0;            ///< consecutive increasing out-of-order stamps so far
  int64_t run_last_ = 0;   ///< the latest of them
};

/// True if the sample should be passed on.
inline bool accepted(StampCheck c) {
  return c == StampCheck::kOk || c == StampCheck::kFirst || c == StampCheck::kGap || c == StampCheck::kRestart;
}

}  // namespace seavio::daemon
