// The visual gyro-bias gain at 1 Hz (the 1 Hz full survey's heading drift). With
// gyro_bias_gain_interval_s 0.1 the gain per frame holds at 10 Hz and scales with sqrt(interval)
// at other frame rates; per frame at any rate (0, the default) the heading bias lagged ~100 s
// behind its random walk on the 1 Hz survey and the heading followed the lag.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/imu/imu_integrator.hpp"
#include "core/odometry/odometry.hpp"
#include "tests/core/odometry/downward_rig.hpp"
#include "tests/core/odometry/floor_frame.hpp"

namespace seavio::odometry {
namespace gyro_bias_rate_test {
namespace {

struct DriftRun {
  double final_bias_error_z = 0;  ///< learnt minus true heading bias at the end [rad/s]
  double max_yaw_error_rad = 0;   ///< largest |yaw| of the chain (truth: 0)
  int vision_frames = 0;
  std::vector<double> bias_z;     ///< learnt heading bias per frame [rad/s]
};

/// Level flight along x at `speed` over a synthetic floor, frames every `dt` s, 4 m above the
/// floor; the gyro's z bias ramps at `ramp` rad/s^2 from t = 0 (after the still second that
/// initialises the odometry, so the still-start estimate is the true zero).
DriftRun fly(double dt, int frames, double speed, double ramp, double gain_interval_s) {
  std::string error;
  auto rectifier = camera::StereoRectifier::create(test::downwardRig(), &error);
  EXPECT_TRUE(rectifier.has_value()) << error;
  const camera::RectifiedRig rig = rectifier->rig();
  OdometryParams params;
  params.gyro_bias_gain_interval_s = gain_interval_s;
  params.gyro_bias_gain = 0.01;  // the gain the bounds below are derived from (the default is 0.02)
  Odometry odo(std::move(*rectifier), imu::ImuNoise{}, params);

  std::mt19937 rng(7);
  std::normal_distribution<double> pix(0.0, 0.1);
  const double length = speed * dt * frames;
  const test::SyntheticFloor floor =
      test::randomFloor(rng, static_cast<int>(160 * (length + 19.0)), -3.0, length + 16.0, 3.0, -4.0);

  DriftRun out;
  int64_t imu_t = -1'000'000'000;
  for (int f = 0; f < frames; ++f) {
    const double t = dt * f;
    const int64_t t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    std::vector<ImuSample> imu;
    for (; imu_t <= t_ns + 5'000'000; imu_t += 5'000'000) {
      ImuSample s;
      s.t_ns = imu_t;
      s.gyro_rad_s = Eigen::Vector3d(0, 0, imu_t > 0 ? ramp * 1e-9 * static_cast<double>(imu_t) : 0.0);
      s.accel_m_s2 = -imu::gravityW();
      imu.push_back(s);
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(speed * t, 0, 0);
    FrameFeatures ff = test::floorFrame(rig, floor.points_W, floor.descriptors, T, static_cast<uint64_t>(f), t_ns, pix, rng);
    const OdometryResult r = odo.track(std::move(ff), imu);
    out.vision_frames += r.source == PoseSource::kVision;
    const Eigen::Matrix3d R = r.T_W_B.linear();
    out.max_yaw_error_rad = std::max(out.max_yaw_error_rad, std::abs(std::atan2(R(1, 0), R(0, 0))));
    out.bias_z.push_back(odo.state().gyro_bias_rad_s.z());
  }
  out.final_bias_error_z = odo.state().gyro_bias_rad_s.z() - ramp * dt * (frames - 1);
  return out;
}

TEST(GyroBiasRate, At1HzTheHeadingBiasFollowsItsDriftWithTheGainScaledBySqrtOfTheInterval) {
  // GIVEN 1 Hz frames 1.5 m apart (the full survey's) and a heading bias drifting at 4e-6
  // rad/s^2 (0.36 mrad/s after 90 s; the simulator's walk reaches ~0.2 mrad/s in 100 s)
  const double ramp = 4e-6;
  // WHEN the gain holds at 10 Hz and scales to 1 Hz (0.032), and per frame at any rate (0.01)
  const DriftRun scaled = fly(1.0, 91, 1.5, ramp, 0.1);
  const DriftRun per_frame = fly(1.0, 91, 1.5, ramp, 0.0);
  RecordProperty("bias_error_urad_s_scaled", static_cast<int>(1e6 * scaled.final_bias_error_z));
  RecordProperty("bias_error_urad_s_per_frame", static_cast<int>(1e6 * per_frame.final_bias_error_z));
  RecordProperty("max_yaw_urad_scaled", static_cast<int>(1e6 * scaled.max_yaw_error_rad));
  RecordProperty("max_yaw_urad_per_frame", static_cast<int>(1e6 * per_frame.max_yaw_error_rad));
  // THEN every frame is visual, and the scaled gain lags the ramp by about its time constant
  // (31.6 s: ramp x tau x (1 - exp(-90 / tau)) = 0.12 mrad/s) where per frame lags by 0.21
  // mrad/s (tau 100 s); the heading, which integrates the lag, stays within a smaller bound
  EXPECT_EQ(scaled.vision_frames, 90);  // all but the first (initialising) frame
  EXPECT_EQ(per_frame.vision_frames, 90);
  EXPECT_LT(std::abs(scaled.final_bias_error_z), 0.6 * ramp * 90.0);
  EXPECT_GT(std::abs(per_frame.final_bias_error_z), 0.5 * ramp * 90.0);
  EXPECT_LT(scaled.max_yaw_error_rad, 0.7 * per_frame.max_yaw_error_rad);
}

TEST(GyroBiasRate, At10HzTheGainIsTheOldPerFrameGainExactly) {
  // GIVEN 10 Hz frames 0.15 m apart and the same drifting bias
  // WHEN the gain is scaled from its 10 Hz interval, and per frame at any rate
  const DriftRun scaled = fly(0.1, 60, 1.5, 4e-6, 0.1);
  const DriftRun per_frame = fly(0.1, 60, 1.5, 4e-6, 0.0);
  // THEN the short surveys' update is unchanged: the same bias, bit for bit, on every frame
  ASSERT_EQ(scaled.bias_z.size(), per_frame.bias_z.size());
  EXPECT_EQ(scaled.vision_frames, 59);
  for (std::size_t i = 0; i < scaled.bias_z.size(); ++i) EXPECT_EQ(scaled.bias_z[i], per_frame.bias_z[i]) << i;
  // and the bias is learnt at all (it moved off the still start's zero towards the ramp)
  EXPECT_GT(scaled.bias_z.back(), 0.1 * 4e-6 * 5.9);
}

}  // namespace
}  // namespace gyro_bias_rate_test
}  // namespace seavio::odometry
