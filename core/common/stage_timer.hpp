#pragma once
/// Per-stage timing with an injected clock, so core never reads a clock itself.
#include <cstdint>

#include "core/common/types.hpp"

namespace seavio {

class StageTimer {
 public:
  explicit StageTimer(const NowNsFn& now) : now_(now), start_ns_(now ? now() : 0), last_ns_(start_ns_) {}
  /// Milliseconds since the previous lap (or construction).
  double lap_ms() {
    if (!now_) return 0.0;
    const int64_t t = now_();
    const double ms = static_cast<double>(t - last_ns_) * 1e-6;
    last_ns_ = t;
    return ms;
  }
  /// Milliseconds since construction.
  double total_ms() const { return now_ ? static_cast<double>(now_() - start_ns_) * 1e-6 : 0.0; }

 private:
  const NowNsFn& now_;
  int64_t start_ns_;
  int64_t last_ns_;
};

}  // namespace seavio
