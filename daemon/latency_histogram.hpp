#pragma once
/// Lock-free latency histogram: one writer records, any thread reads percentiles.
/// Log-spaced bins from 10 us to ~100 s, 5 % wide, so p50/p99 are within 5 %.
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>

namespace seavio::daemon {

class LatencyHistogram {
 public:
  static constexpr std::size_t kBins = 330;

  /// Adds one sample [ms]. Negative or non-finite samples go to the lowest bin / are
  /// ignored respectively.
  void record(double ms);
  /// Value [ms] below which `q` (0..1) of the samples lie (upper edge of that bin);
  /// 0 if empty.
  double percentileMs(double q) const;
  double maxMs() const;
  uint64_t count() const { return count_.load(std::memory_order_relaxed); }

 private:
  static std::size_t binOf(double ms);
  static double upperEdgeMs(std::size_t bin);

  std::array<std::atomic<uint64_t>, kBins> bins_{};
  std::atomic<uint64_t> count_{0};
  std::atomic<uint64_t> max_us_{0};
};

}  // namespace seavio::daemon
