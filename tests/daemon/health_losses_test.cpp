// The daemon's IMU-only counter and, beside it, how those frames coasted: corrected
// by the leak the last fixes agree on, or covariance-only because they disagreed.
#include <gtest/gtest.h>

#include "daemon/health.hpp"

namespace seavio::daemon {
namespace health_losses_test {
namespace {

OdometryResult result(PoseSource source, CoastingCorrection coasting) {
  OdometryResult r;
  r.source = source;
  r.coasting = coasting;
  return r;
}

TEST(HealthLosses, ImuOnlyFramesAreCountedWithHowTheirCoastingWasCorrected) {
  // GIVEN fresh counters
  HealthCounters h;
  // WHEN visual frames and IMU-only frames of every kind are counted
  countImuOnly(h, result(PoseSource::kInit, CoastingCorrection::kNone));
  countImuOnly(h, result(PoseSource::kVision, CoastingCorrection::kNone));
  countImuOnly(h, result(PoseSource::kImuOnly, CoastingCorrection::kAgreedLeak));
  countImuOnly(h, result(PoseSource::kImuOnly, CoastingCorrection::kAgreedLeak));
  countImuOnly(h, result(PoseSource::kImuOnly, CoastingCorrection::kCovarianceOnly));
  countImuOnly(h, result(PoseSource::kImuOnly, CoastingCorrection::kBare));
  countImuOnly(h, result(PoseSource::kImuOnly, CoastingCorrection::kHandoverFit));
  countImuOnly(h, result(PoseSource::kImuOnly, CoastingCorrection::kHeld));
  // THEN every IMU-only frame counts once, and of them the agreed-leak and covariance-only ones
  EXPECT_EQ(h.imu_only_frames.load(), 6u);
  EXPECT_EQ(h.imu_only_leak_corrected.load(), 2u);
  EXPECT_EQ(h.imu_only_covariance_only.load(), 1u);
}

}  // namespace
}  // namespace health_losses_test
}  // namespace seavio::daemon
