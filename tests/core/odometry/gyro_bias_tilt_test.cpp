// A visual rotation with a pitch rate that is not the vehicle's (over a flat floor the
// prior-free four-view rotation couples pitch with surge) must not be learnt into the gyro bias.
// The vehicle flies level at 1 m/s and the gyro has no bias; the frames are rendered from a
// camera that pitches slowly, as the biased visual rotation would have it. The old update learns
// that pitch rate as a gyro bias and the gyro prior then carries it into the attitude; with the
// heading-only visual update and the tilt rates from gravity the attitude stays level.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/imu/imu_integrator.hpp"
#include "core/odometry/odometry.hpp"
#include "tests/core/odometry/downward_rig.hpp"
#include "tests/core/odometry/floor_frame.hpp"

namespace seavio::odometry {
namespace gyro_bias_tilt_test {
namespace {

constexpr double kSpeed = 1.0;            // [m/s], level flight along x, 4 m above the floor
constexpr double kVisualPitchRate = 2e-3;  // [rad/s], seed 23 plain's drift was 2.5e-3
constexpr int kFrames = 250;              // 25 s at 10 Hz

struct TiltRun {
  double final_pitch_error_rad = 0;   ///< the chain's pitch against the level truth
  double final_pitch_rad = 0;         ///< signed: nose up is positive
  double pitch_bias_rad_s = 0;        ///< the learnt gyro bias about the body's y axis
  double final_chain_pitch_rad = 0;   ///< the chain's own (Odometry::state), signed
  double max_published_z_step_m = 0;  ///< largest frame-to-frame z step of the published path
  int vision_frames = 0;
};

/// `visual_pitch_rate_rad_s`: the rendered camera's pitch rate; `accel_bias_m_s2`: a bias the
/// accelerometer takes on as the flight starts (the still start before it levels the chain).
TiltRun fly(const OdometryParams& params, double visual_pitch_rate_rad_s = kVisualPitchRate,
            const Eigen::Vector3d& accel_bias_m_s2 = Eigen::Vector3d::Zero()) {
  std::string error;
  auto rectifier = camera::StereoRectifier::create(test::downwardRig(), &error);
  EXPECT_TRUE(rectifier.has_value()) << error;
  const camera::RectifiedRig rig = rectifier->rig();
  Odometry odo(std::move(*rectifier), imu::ImuNoise{}, params);

  std::mt19937 rng(23);
  std::normal_distribution<double> pix(0.0, 0.1);
  const test::SyntheticFloor floor = test::randomFloor(rng, 7000, -3.0, 30.0, 3.0, -4.0);
  // The pose the frames are rendered from: the true path, pitched at the visual pitch rate.
  const auto rendered = [visual_pitch_rate_rad_s](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(visual_pitch_rate_rad_s * t, Eigen::Vector3d::UnitY()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(kSpeed * t, 0, 0);
    return T;
  };

  TiltRun out;
  int64_t imu_t = -1'000'000'000;
  Eigen::Matrix3d R_last = Eigen::Matrix3d::Identity();
  double z_last = 0;
  for (int f = 0; f < kFrames; ++f) {
    const double t = 0.1 * f;
    const int64_t t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    std::vector<ImuSample> imu = test::levelImuUntil(imu_t, t_ns, Eigen::Vector3d::Zero());  // no gyro bias
    for (ImuSample& s : imu)
      if (s.t_ns > 0) s.accel_m_s2 += accel_bias_m_s2;
    FrameFeatures ff = test::floorFrame(rig, floor.points_W, floor.descriptors, rendered(t), static_cast<uint64_t>(f),
                                        t_ns, pix, rng);
    EXPECT_GT(ff.stereo.points.size(), 100u);
    const OdometryResult r = odo.track(std::move(ff), imu);
    out.vision_frames += r.source == PoseSource::kVision;
    R_last = r.T_W_B.linear();
    if (f > 0) out.max_published_z_step_m = std::max(out.max_published_z_step_m, std::abs(r.T_W_B.translation().z() - z_last));
    z_last = r.T_W_B.translation().z();
  }
  // Pitch: the body's x axis out of the horizontal plane.
  const auto pitch = [](const Eigen::Matrix3d& R) { return -std::asin(std::clamp(R(2, 0), -1.0, 1.0)); };
  out.final_chain_pitch_rad = pitch(odo.state().T_W_B.linear());
  out.final_pitch_rad = pitch(R_last);
  out.final_pitch_error_rad = std::abs(out.final_pitch_rad);
  out.pitch_bias_rad_s = odo.state().gyro_bias_rad_s.y();
  return out;
}

TEST(GyroBiasTilt, AVisualPitchRateIsNotLearntIntoTheAttitudeWithGravityAsTheTiltReference) {
  // GIVEN the earlier update (all three axes from the visual residual) and the new one
  // (heading from vision, tilt rates from gravity over 2 s windows)
  OdometryParams old_params;
  old_params.accel_bias_estimation = false;  // gravity's tilt rates alone, not the bias filter's tilt
  old_params.gyro_bias_vision_tilt_weight = 1.0;
  old_params.gyro_bias_gravity_window_s = 0.0;
  OdometryParams new_params;
  new_params.accel_bias_estimation = false;  // gravity's tilt rates alone, not the bias filter's tilt
  new_params.gyro_bias_vision_tilt_weight = 0.0;
  new_params.gyro_bias_gravity_window_s = 2.0;
  // WHEN both fly 25 s over frames whose visual rotation pitches at 2 mrad/s
  const TiltRun before = fly(old_params);
  const TiltRun after = fly(new_params);
  RecordProperty("pitch_error_urad_before", static_cast<int>(1e6 * before.final_pitch_error_rad));
  RecordProperty("pitch_error_urad_after", static_cast<int>(1e6 * after.final_pitch_error_rad));
  RecordProperty("pitch_bias_urad_s_before", static_cast<int>(1e6 * before.pitch_bias_rad_s));
  RecordProperty("pitch_bias_urad_s_after", static_cast<int>(1e6 * after.pitch_bias_rad_s));
  EXPECT_EQ(before.vision_frames, kFrames - 1);
  EXPECT_EQ(after.vision_frames, kFrames - 1);
  // THEN the earlier update learns the visual pitch rate as a gyro bias and pitches the
  // attitude by much of the 50 mrad the frames were rendered with...
  EXPECT_GT(std::abs(before.pitch_bias_rad_s), 0.5 * kVisualPitchRate);
  EXPECT_GT(before.final_pitch_error_rad, 0.02);
  // ...and the new one keeps it within a third of that: gravity sees the chain pitching and
  // turns the pitch bias against the visual rate (the prior then pulls the other way)
  EXPECT_LT(after.final_pitch_error_rad, before.final_pitch_error_rad / 3);
  EXPECT_LT(after.pitch_bias_rad_s * before.pitch_bias_rad_s, 0.0);
}

TEST(GyroBiasTilt, AGravityTiltCorrectionIsNotReadAsAGyroBiasRate) {
  // The absolute tilt references (gravity_tilt_time_constant_s, accel_bias_estimation) turn the
  // chain a little after each frame. The tilt-rate observer compares the chain's tilt between
  // windows: unless its windows turn with the chain, each correction reads as a pitch rate of
  // the gyro bias, which the prior then carries back into the attitude against the reference.
  // GIVEN a level flight whose accelerometer takes on 0.05 m/s^2 along x as it starts, so that
  // gravity says the chain is pitched by 5 mrad, no visual pitch rate and a bias-free gyro
  OdometryParams params;
  params.accel_bias_estimation = false;  // it replaces gravity_tilt_time_constant_s when on
  params.gyro_bias_vision_tilt_weight = 0.0;
  params.gyro_bias_gravity_window_s = 2.0;
  params.gravity_tilt_time_constant_s = 5.0;
  const Eigen::Vector3d accel_bias(0.05, 0.0, 0.0);
  // WHEN it flies 25 s with gravity as the tilt reference (5 s time constant)
  const TiltRun run = fly(params, 0.0, accel_bias);
  RecordProperty("pitch_urad", static_cast<int>(1e6 * run.final_pitch_rad));
  RecordProperty("pitch_bias_urad_s", static_cast<int>(1e6 * run.pitch_bias_rad_s));
  EXPECT_EQ(run.vision_frames, kFrames - 1);
  // THEN the chain follows the reference (five time constants: within a few percent of b/g,
  // whose sign the frame convention sets)...
  const double reference_rad = accel_bias.x() / imu::kGravity_m_s2;
  EXPECT_NEAR(std::abs(run.final_pitch_rad), reference_rad, 0.15 * reference_rad);
  // ...and the gyro's pitch bias stays near its true zero: a rate that made up for the
  // corrections would be of the order of b/g over the time constant, 1 mrad/s
  EXPECT_LT(std::abs(run.pitch_bias_rad_s), 5e-5);
}

TEST(GyroBiasTilt, WithTheStartUpFrameThePublishedAttitudeKeepsTheFrameTheChainLevelledIn) {
  // accel_bias_start_frame: the accelerometer-bias filter turns the chain by what it takes for
  // tilt, and the tilt it takes for the start-up levelling's error moves the published frame
  // back with it, frame by frame. On a straight leg the two cannot be told apart.
  // GIVEN the level flight whose accelerometer takes on 0.05 m/s^2 as it starts (the still
  // start levelled it true), the filter on, with and without the start-up frame
  OdometryParams chain_params;
  chain_params.gyro_bias_gravity_window_s = 2.0;
  chain_params.accel_bias_estimation = true;
  chain_params.accel_bias_start_frame = false;
  OdometryParams start_params = chain_params;
  start_params.accel_bias_start_frame = true;
  const Eigen::Vector3d accel_bias(0.05, 0.0, 0.0);
  // WHEN both fly 25 s
  const TiltRun chain = fly(chain_params, 0.0, accel_bias);
  const TiltRun start = fly(start_params, 0.0, accel_bias);
  RecordProperty("chain_pitch_urad", static_cast<int>(1e6 * chain.final_pitch_rad));
  RecordProperty("start_frame_pitch_urad", static_cast<int>(1e6 * start.final_pitch_rad));
  RecordProperty("start_frame_chain_pitch_urad", static_cast<int>(1e6 * start.final_chain_pitch_rad));
  EXPECT_EQ(chain.vision_frames, kFrames - 1);
  EXPECT_EQ(start.vision_frames, kFrames - 1);
  // THEN the chain pitches towards the accelerometer's b / g (5 mrad) in both, the same
  // chain, and without the start-up frame that is what is published...
  EXPECT_GT(std::abs(chain.final_chain_pitch_rad), 1e-3);
  EXPECT_NEAR(start.final_chain_pitch_rad, chain.final_chain_pitch_rad, 1e-9);
  EXPECT_NEAR(chain.final_pitch_rad, chain.final_chain_pitch_rad, 1e-9);
  // ...while the start-up frame publishes the attitude level, as it started, and its path
  // without a jump (0.1 m per frame along x; a turn of the published frame about the start
  // would move z by up to 25 m x the turn)
  EXPECT_LT(std::abs(start.final_pitch_rad), 0.2 * std::abs(chain.final_chain_pitch_rad));
  EXPECT_LT(start.max_published_z_step_m, 1e-3);
}

}  // namespace
}  // namespace gyro_bias_tilt_test
}  // namespace seavio::odometry
