#pragma once
/// Classifies each new timestamp of a stream against the previous accepted one, so the
/// daemon counts out-of-order, duplicate and jumping timestamps (issue 9) instead of
/// feeding them to the estimator.
#include <cstdint>

namespace seavio::daemon {

enum class StampCheck {
  kOk,          ///< strictly increasing, within the gap limit
  kFirst,       ///< first sample of the stream
  kDuplicate,   ///< equal to the previous one: reject
  kOutOfOrder,  ///< earlier than the previous one: reject
  kGap,         ///< later than previous + max_gap_ns: accept, but count a gap
};

class TimestampMonitor {
 public:
  /// @param max_gap_ns a step larger than this counts as a gap [ns]
  explicit TimestampMonitor(int64_t max_gap_ns) : max_gap_ns_(max_gap_ns) {}
  /// Checks `t_ns` and, unless rejected, makes it the new reference.
  StampCheck check(int64_t t_ns);
  int64_t last() const { return last_; }

 private:
  int64_t max_gap_ns_;
  int64_t last_ = 0;
  bool have_ = false;
};

/// True if the sample should be passed on.
inline bool accepted(StampCheck c) {
  return c == StampCheck::kOk || c == StampCheck::kFirst || c == StampCheck::kGap;
}

}  // namespace seavio::daemon
