#include "daemon/latency_histogram.hpp"

#include <algorithm>
#include <cmath>

namespace seavio::daemon {

namespace {
constexpr double kMinMs = 0.01;
constexpr double kGrowth = 1.05;
}  // namespace

std::size_t LatencyHistogram::binOf(double ms) {
  if (ms <= kMinMs) return 0;
  const double b = std::ceil(std::log(ms / kMinMs) / std::log(kGrowth));
  return std::min<std::size_t>(kBins - 1, static_cast<std::size_t>(b));
}

double LatencyHistogram::upperEdgeMs(std::size_t bin) {
  return kMinMs * std::pow(kGrowth, static_cast<double>(bin));
}

void LatencyHistogram::record(double ms) {
  if (!std::isfinite(ms)) return;
  bins_[binOf(ms)].fetch_add(1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
  const auto us = static_cast<uint64_t>(std::max(0.0, ms) * 1000.0);
  uint64_t prev = max_us_.load(std::memory_order_relaxed);
  while (us > prev && !max_us_.compare_exchange_weak(prev, us, std::memory_order_relaxed)) {
  }
}

double LatencyHistogram::percentileMs(double q) const {
  std::array<uint64_t, kBins> snap{};
  uint64_t total = 0;
  for (std::size_t i = 0; i < kBins; ++i) {
    snap[i] = bins_[i].load(std::memory_order_relaxed);
    total += snap[i];
  }
  if (total == 0) return 0.0;
  const double target = std::clamp(q, 0.0, 1.0) * static_cast<double>(total);
  uint64_t acc = 0;
  for (std::size_t i = 0; i < kBins; ++i) {
    acc += snap[i];
    if (static_cast<double>(acc) >= target && snap[i] > 0) {
      return std::min(upperEdgeMs(i), std::max(maxMs(), upperEdgeMs(0)));
    }
  }
  return maxMs();
}

double LatencyHistogram::maxMs() const {
  return static_cast<double>(max_us_.load(std::memory_order_relaxed)) / 1000.0;
}

}  // namespace seavio::daemon
