// The gyro bias learnt from vision (local keyframe tracking): a bias the still start could not
// see (it appears once the vehicle moves) must be learnt from the prior-free four-view rotation,
// once per keyframe span (gyro_bias_per_keyframe) at least as well as from every frame.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/imu/imu_integrator.hpp"
#include "core/odometry/odometry.hpp"
#include "tests/core/odometry/downward_rig.hpp"
#include "tests/core/odometry/floor_frame.hpp"

namespace seavio::odometry {
namespace gyro_bias_test {
namespace {

constexpr double kSpeed = 1.0;  // [m/s], level flight along x, 4 m above the floor

struct BiasRun {
  Eigen::Vector3d final_bias_error = Eigen::Vector3d::Zero();  ///< learnt minus true [rad/s]
  double final_attitude_error_rad = 0;
  int vision_frames = 0;
};

/// 12 s over a synthetic floor; the gyro reads `bias` from t = 0 on (after the still second
/// that initialises the odometry, so the still-start estimate is zero).
BiasRun fly(const Eigen::Vector3d& bias, bool per_keyframe) {
  std::string error;
  auto rectifier = camera::StereoRectifier::create(test::downwardRig(), &error);
  EXPECT_TRUE(rectifier.has_value()) << error;
  const camera::RectifiedRig rig = rectifier->rig();
  OdometryParams params;
  params.gyro_bias_per_keyframe = per_keyframe;
  // All three axes from vision, as this test compares how the visual residual is learnt (the
  // default takes only the heading from vision and the tilt rates from gravity, which sees no
  // tilt drift here: gyro_bias_tilt_test.cpp).
  params.gyro_bias_vision_tilt_weight = 1.0;
  params.gyro_bias_gravity_window_s = 0.0;
  // The gain and the tilt references this comparison's bounds were set with: 0.01 per frame,
  // and no accelerometer-bias filter turning the chain.
  params.gyro_bias_gain = 0.01;
  params.accel_bias_estimation = false;
  Odometry odo(std::move(*rectifier), imu::ImuNoise{}, params);

  std::mt19937 rng(11);
  std::normal_distribution<double> pix(0.0, 0.1);
  const test::SyntheticFloor floor = test::randomFloor(rng, 3000, -3.0, 16.0, 3.0, -4.0);
  const auto pose = [](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(kSpeed * t, 0, 0);
    return T;
  };

  BiasRun out;
  const int frames = 120;
  int64_t imu_t = -1'000'000'000;
  Eigen::Matrix3d R_last = Eigen::Matrix3d::Identity();
  for (int f = 0; f < frames; ++f) {
    const double t = 0.1 * f;
    const int64_t t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    const std::vector<ImuSample> imu = test::levelImuUntil(imu_t, t_ns, bias);
    FrameFeatures ff = test::floorFrame(rig, floor.points_W, floor.descriptors, pose(t), static_cast<uint64_t>(f), t_ns, pix, rng);
    EXPECT_GT(ff.stereo.points.size(), 100u);
    const OdometryResult r = odo.track(std::move(ff), imu);
    out.vision_frames += r.source == PoseSource::kVision;
    R_last = r.T_W_B.linear();
  }
  out.final_bias_error = odo.state().gyro_bias_rad_s - bias;
  out.final_attitude_error_rad = Eigen::AngleAxisd(R_last).angle();  // truth: identity
  return out;
}

TEST(GyroBiasLearning, PerKeyframeSpanLearnsAnUnseenBiasAtLeastAsWellAsPerFrame) {
  // GIVEN a gyro bias of 1 mrad/s about each axis that the still start did not see
  const Eigen::Vector3d bias(1e-3, -1e-3, 1e-3);
  // WHEN the odometry learns it from vision once per keyframe span, and from every frame
  const BiasRun per_kf = fly(bias, true);
  const BiasRun per_frame = fly(bias, false);
  RecordProperty("bias_error_urad_s_per_keyframe", static_cast<int>(1e6 * per_kf.final_bias_error.norm()));
  RecordProperty("bias_error_urad_s_per_frame", static_cast<int>(1e6 * per_frame.final_bias_error.norm()));
  RecordProperty("attitude_error_urad_per_keyframe", static_cast<int>(1e6 * per_kf.final_attitude_error_rad));
  RecordProperty("attitude_error_urad_per_frame", static_cast<int>(1e6 * per_frame.final_attitude_error_rad));
  // THEN every frame is visual, most of the bias is learnt within 12 s (gain 0.01 per frame at
  // 10 Hz: a 10 s time constant, so about 70 %), and per keyframe is no worse than per frame
  EXPECT_EQ(per_kf.vision_frames, 119);  // all but the first (initialising) frame
  EXPECT_EQ(per_frame.vision_frames, 119);
  EXPECT_LT(per_kf.final_bias_error.norm(), 0.5 * bias.norm());
  EXPECT_LT(per_frame.final_bias_error.norm(), 0.5 * bias.norm());
  EXPECT_LT(per_kf.final_bias_error.norm(), 1.2 * per_frame.final_bias_error.norm() + 2e-5);
  EXPECT_LT(per_kf.final_attitude_error_rad, 1.2 * per_frame.final_attitude_error_rad + 2e-4);
}

}  // namespace
}  // namespace gyro_bias_test
}  // namespace seavio::odometry
