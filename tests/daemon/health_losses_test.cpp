// The daemon's IMU-only counter with the check that refused each of those frames, and beside
// it the frames on which the IMU was judged at fault.
#include <gtest/gtest.h>

#include "daemon/health.hpp"

namespace seavio::daemon {
namespace health_losses_test {
namespace {

OdometryResult result(PoseSource source, Refusal refusal, bool imu_fault = false) {
  OdometryResult r;
  r.source = source;
  r.coasting = source == PoseSource::kImuOnly ? CoastingCorrection::kInertial : CoastingCorrection::kNone;
  r.refusal.check = refusal;
  r.quality.imu_fault = imu_fault;
  return r;
}

TEST(HealthLosses, ImuOnlyFramesAreCountedByTheirRefusalAndImuFaultsApart) {
  // GIVEN fresh counters
  HealthCounters h;
  // WHEN visual frames (one with the IMU judged at fault) and IMU-only frames are counted
  countPose(h, result(PoseSource::kInit, Refusal::kNone));
  countPose(h, result(PoseSource::kVision, Refusal::kNone));
  countPose(h, result(PoseSource::kVision, Refusal::kNone, true));
  countPose(h, result(PoseSource::kImuOnly, Refusal::kInertialGate));
  countPose(h, result(PoseSource::kImuOnly, Refusal::kInertialGate));
  countPose(h, result(PoseSource::kImuOnly, Refusal::kInliers));
  // THEN every IMU-only frame counts once, under the check that refused it, and the fault once
  EXPECT_EQ(h.imu_only_frames.load(), 3u);
  EXPECT_EQ(h.imu_only_refused[static_cast<std::size_t>(Refusal::kInertialGate)].load(), 2u);
  EXPECT_EQ(h.imu_only_refused[static_cast<std::size_t>(Refusal::kInliers)].load(), 1u);
  EXPECT_EQ(h.imu_faults.load(), 1u);
}

}  // namespace
}  // namespace health_losses_test
}  // namespace seavio::daemon
