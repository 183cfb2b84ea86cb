#include <gtest/gtest.h>

#include <random>

#include "daemon/latency_histogram.hpp"
#include "daemon/timestamp_monitor.hpp"

namespace seavio::daemon {
namespace latency_and_stamps_test {
namespace {

TEST(LatencyHistogram, PercentilesWithinBinWidth) {
  LatencyHistogram h;
  for (int i = 1; i <= 1000; ++i) h.record(0.1 * i);  // 0.1 .. 100 ms uniform
  EXPECT_EQ(h.count(), 1000u);
  EXPECT_NEAR(h.percentileMs(0.5), 50.0, 50.0 * 0.06);
  EXPECT_NEAR(h.percentileMs(0.99), 99.0, 99.0 * 0.06);
  EXPECT_NEAR(h.maxMs(), 100.0, 0.01);
  EXPECT_LE(h.percentileMs(1.0), h.maxMs() + 1e-9);
}

TEST(LatencyHistogram, EmptyAndOddSamples) {
  LatencyHistogram h;
  EXPECT_EQ(h.percentileMs(0.5), 0.0);
  h.record(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(h.count(), 0u);
  h.record(-3.0);
  h.record(1e9);
  EXPECT_EQ(h.count(), 2u);
  EXPECT_GT(h.percentileMs(0.99), 1000.0);
}

TEST(LatencyHistogram, SkewedDistributionP99) {
  LatencyHistogram h;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> base(10, 12);
  for (int i = 0; i < 990; ++i) h.record(base(rng));
  for (int i = 0; i < 10; ++i) h.record(80.0);
  EXPECT_LT(h.percentileMs(0.5), 13.0);
  EXPECT_LT(h.percentileMs(0.98), 13.0);
  EXPECT_GT(h.percentileMs(0.995), 70.0);
}

TEST(TimestampMonitor, ClassifiesEveryCase) {
  TimestampMonitor m(100);
  EXPECT_EQ(m.check(1000), StampCheck::kFirst);
  EXPECT_EQ(m.check(1050), StampCheck::kOk);
  EXPECT_EQ(m.check(1050), StampCheck::kDuplicate);
  EXPECT_EQ(m.check(1000), StampCheck::kOutOfOrder);
  EXPECT_EQ(m.last(), 1050);  // rejected stamps do not move the reference
  EXPECT_EQ(m.check(1500), StampCheck::kGap);
  EXPECT_EQ(m.check(1550), StampCheck::kOk);
  EXPECT_TRUE(accepted(StampCheck::kGap));
  EXPECT_FALSE(accepted(StampCheck::kDuplicate));
  EXPECT_FALSE(accepted(StampCheck::kOutOfOrder));
}

}  // namespace
}  // namespace latency_and_stamps_test
}  // namespace seavio::daemon
