#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "core/imu/accel_bias_estimator.hpp"
#include "core/imu/imu_integrator.hpp"

namespace seavio::imu {
namespace accel_bias_estimator_test {
namespace {

int64_t ns(double t_s) { return static_cast<int64_t>(std::llround(t_s * 1e9)); }

// A lawnmower leg pair at 1.5 m/s, level: 5 s still, 60 s along +x, a 180 deg turn in 20 s,
// 60 s back (the paper survey's pattern at 1 Hz frames).
struct Lawnmower {
  static constexpr double kSpeed = 1.5, kStill = 5, kLeg = 60, kTurn = 20;
  double yawRate(double t) const {
    return t > kStill + kLeg && t < kStill + kLeg + kTurn ? std::numbers::pi / kTurn : 0.0;
  }
  double yaw(double t) const {
    const double s = std::clamp(t - kStill - kLeg, 0.0, kTurn);
    return std::numbers::pi * s / kTurn;
  }
  double speed(double t) const { return t < kStill ? 0.0 : kSpeed; }
  Eigen::Matrix3d R(double t) const { return Eigen::AngleAxisd(yaw(t), Eigen::Vector3d::UnitZ()).toRotationMatrix(); }
  Eigen::Vector3d v(double t) const { return speed(t) * Eigen::Vector3d(std::cos(yaw(t)), std::sin(yaw(t)), 0); }
  // Centripetal only (the start from rest is a step, taken at a sample boundary below).
  Eigen::Vector3d a(double t) const {
    return speed(t) * yawRate(t) * Eigen::Vector3d(-std::sin(yaw(t)), std::cos(yaw(t)), 0);
  }
  ImuSample sample(double t, const Eigen::Vector3d& bias_B, std::mt19937& rng, double accel_noise) const {
    std::normal_distribution<double> n(0.0, accel_noise);
    return ImuSample{ns(t), Eigen::Vector3d(0, 0, yawRate(t)),
                     R(t).transpose() * (a(t) - gravityW()) + bias_B + Eigen::Vector3d(n(rng), n(rng), n(rng))};
  }
};

struct Flight {
  std::vector<Eigen::Vector3d> bias_error;  // per frame, after its update
  std::vector<double> tilt_error_rad;       // the chain's roll/pitch error per frame
  std::vector<Eigen::Vector3d> gyro_bias_error;  // the chain's gyro bias error per frame [rad/s]
  std::vector<Eigen::Vector2d> gyro_bias_sigma;  // gyroBiasCovariance()'s sigmas per frame [rad/s]
  /// Roll/pitch of the chain turned back by the start-up tilt estimate (the published
  /// attitude with OdometryParams::accel_bias_start_frame) against the start-up error, per frame
  std::vector<double> start_frame_error_rad;
  Eigen::Vector2d start_tilt_rad = Eigen::Vector2d::Zero();           // true start-up tilt error
  Eigen::Vector2d start_tilt_estimate_rad = Eigen::Vector2d::Zero();  // initialTilt() at the end
};

// The odometry's use of the estimator, with vision replaced by the true velocity seen through
// the chain's tilt error plus noise: levelled by the biased accelerometer at the start, then
// one interval per 1 Hz frame, the chain turned by every correction.
// `gyro_bias_error_B`: the chain also integrates a horizontal gyro bias error, which turns its
// tilt steadily; the estimator's corrections of it (gyro_bias_states) are fed back.
Flight fly(const Eigen::Vector3d& bias_B, const AccelBiasParams& params, bool estimate, uint32_t seed,
           Eigen::Vector3d gyro_bias_error_B = Eigen::Vector3d::Zero()) {
  const Lawnmower path;
  std::mt19937 rng(seed);
  const double rate = 200, noise = params.accel_noise_density * std::sqrt(rate);
  std::vector<ImuSample> imu;
  for (int i = 0; i <= static_cast<int>((2 * Lawnmower::kLeg + Lawnmower::kTurn + Lawnmower::kStill) * rate); ++i)
    imu.push_back(path.sample(i / rate, bias_B, rng, noise));
  std::vector<ImuSample> still;
  for (const ImuSample& s : imu)
    if (s.t_ns <= ns(1.0)) still.push_back(s);
  const Eigen::Matrix3d R0 = *attitudeFromAccelerometer(still);
  // The chain's attitude error in W; the vehicle is level, so levelling put the bias into it.
  Eigen::Matrix3d E = R0 * path.R(0).transpose();
  const Eigen::Matrix3d E0 = E;
  AccelBiasEstimator est(params);
  est.reset(R0, true, 1e-3, 3e-4);  // gyro-bias sigma: ~2.5x the horizontal errors flown below
  std::normal_distribution<double> vel_noise(0.0, 0.01);
  const auto visualVelocity = [&](double t) {
    return Eigen::Vector3d(E * path.v(t) + Eigen::Vector3d(vel_noise(rng), vel_noise(rng), vel_noise(rng)));
  };
  Flight run;
  est.startWindow(visualVelocity(1.0));
  const int frames = static_cast<int>(2 * Lawnmower::kLeg + Lawnmower::kTurn + Lawnmower::kStill) - 1;
  for (int k = 1; k < frames; ++k) {
    const double t0 = k, t1 = k + 1;
    std::vector<ImuSample> span;
    for (const ImuSample& s : imu)
      if (s.t_ns >= ns(t0 - 0.01) && s.t_ns <= ns(t1 + 0.01)) span.push_back(s);
    est.addInterval(E * path.R(t0), Eigen::Vector3d::Zero(), span, ns(t0), ns(t1));
    E = se3::expSO3(E * path.R(t0) * gyro_bias_error_B * (t1 - t0)) * E;
    if (estimate && est.close(visualVelocity(t1)) == AccelBiasEstimator::Outcome::kUpdated) {
      E = se3::expSO3(est.tiltCorrection()) * E;
      gyro_bias_error_B -= est.gyroBiasCorrection();
    }
    // The next window starts here, from the chain's velocity turned with it (after a refusal
    // too: the start from rest is a step the IMU samples do not hold).
    if (!est.windowOpen()) est.startWindow(visualVelocity(t1));
    run.bias_error.push_back(est.bias() - bias_B);
    const Eigen::Vector3d tilt = se3::logSO3(E);
    run.tilt_error_rad.push_back(std::hypot(tilt.x(), tilt.y()));
    const Eigen::Vector3d published = se3::logSO3(se3::expSO3(est.initialTilt()) * E * E0.transpose());
    run.start_frame_error_rad.push_back(std::hypot(published.x(), published.y()));
    run.gyro_bias_error.push_back(gyro_bias_error_B);
    run.gyro_bias_sigma.push_back(est.gyroBiasCovariance().diagonal().cwiseSqrt());
  }
  run.start_tilt_rad = se3::logSO3(E0).head<2>();
  run.start_tilt_estimate_rad = est.initialTilt().head<2>();
  return run;
}

// A constant horizontal bias of 0.3 m/s^2 (30 mrad of apparent tilt), and the filter set for it.
const Eigen::Vector3d kLargeBias(0.25, -0.17, 0.06);
AccelBiasParams largeBiasParams() {
  AccelBiasParams params;
  params.initial_bias_sigma_m_s2 = 0.3;
  params.bias_random_walk_m_s2_sqrt_s = 1e-4;
  params.tilt_random_walk_rad_sqrt_s = 1e-4;
  params.velocity_sigma_m_s = 0.01;
  return params;
}

TEST(AccelBiasEstimator, ConstantBiasIsFoundAcrossTheTurnAndTheTiltHeldToGravity) {
  // GIVEN a constant accelerometer bias of 0.3 m/s^2 horizontally (the simulator's drift over
  // the 4.5 km survey: 30 mrad of apparent tilt) and a chain levelled by that accelerometer
  const AccelBiasParams params = largeBiasParams();
  // WHEN the estimator runs over a leg, a 180 deg turn and the leg back
  const Flight with = fly(kLargeBias, params, true, 7);
  const Flight without = fly(kLargeBias, params, false, 7);
  // THEN on the first leg only the vertical bias is known: horizontally, bias and tilt read
  // the same...
  const std::size_t before_turn = static_cast<std::size_t>(Lawnmower::kStill + Lawnmower::kLeg) - 3;
  EXPECT_LT(std::abs(with.bias_error[before_turn].z()), 0.01);
  EXPECT_GT(with.bias_error[before_turn].head<2>().norm(), 0.1);
  // ...after the turn all three components are within 0.01 m/s^2 (1 mrad of tilt) and the
  // chain's roll/pitch within 1.5 mrad of the truth, where the levelled chain without the
  // estimator keeps the bias's 30 mrad
  const Eigen::Vector3d last = with.bias_error.back();
  EXPECT_LT(last.cwiseAbs().maxCoeff(), 0.01) << last.transpose();
  EXPECT_LT(with.tilt_error_rad.back(), 1.5e-3);
  EXPECT_GT(without.tilt_error_rad.back(), 0.025);
  EXPECT_GT(without.bias_error.back().norm(), 0.29);
}

// The paper IMU's accelerometer bias (0.03 m/s^2) and a horizontal gyro bias error a still
// start leaves (1.2e-4 rad/s: the chain's tilt turns 7 mrad a minute).
const Eigen::Vector3d kPaperAccelBias(0.02, -0.02, 0.01), kStillStartGyroError(1.0e-4, -0.7e-4, 0.0);

TEST(AccelBiasEstimator, WithGyroBiasStatesAHorizontalGyroBiasErrorIsLearntInsteadOfTiltingTheChain) {
  // GIVEN the paper IMU's accelerometer bias and the gyro bias error a still start leaves
  const Eigen::Vector3d &accel_bias = kPaperAccelBias, &gyro_error = kStillStartGyroError;
  AccelBiasParams walk;  // the tilt's random walk alone follows the turning chain
  walk.gyro_bias_states = false;
  walk.tilt_random_walk_rad_sqrt_s = 1e-3;
  walk.bias_random_walk_m_s2_sqrt_s = 4e-5;
  walk.velocity_sigma_m_s = 0.01;
  AccelBiasParams states = walk;
  states.gyro_bias_states = true;
  states.tilt_random_walk_rad_sqrt_s = 2e-4;
  // WHEN the estimator runs over the leg, the turn and the leg back, both ways
  double worst_walk = 0, worst_states = 0, mean_walk = 0, mean_states = 0;
  Eigen::Vector3d bias_walk = Eigen::Vector3d::Zero(), bias_states = Eigen::Vector3d::Zero();
  for (uint32_t seed : {3u, 4u, 5u}) {
    const Flight a = fly(accel_bias, walk, true, seed, gyro_error), b = fly(accel_bias, states, true, seed, gyro_error);
    for (std::size_t k = 0; k < a.tilt_error_rad.size(); ++k) {
      worst_walk = std::max(worst_walk, a.tilt_error_rad[k]);
      worst_states = std::max(worst_states, b.tilt_error_rad[k]);
      mean_walk += a.tilt_error_rad[k] / (3.0 * a.tilt_error_rad.size());
      mean_states += b.tilt_error_rad[k] / (3.0 * b.tilt_error_rad.size());
    }
    bias_walk += a.bias_error.back().cwiseAbs() / 3.0;
    bias_states += b.bias_error.back().cwiseAbs() / 3.0;
    // THEN the gyro bias error is learnt: a third of it is left by the end
    EXPECT_LT(b.gyro_bias_error.back().norm(), gyro_error.norm() / 3) << "seed " << seed;
    EXPECT_EQ(a.gyro_bias_error.back(), gyro_error) << "without the states nothing is learnt";
  }
  RecordProperty("mean_tilt_error_urad_walk", static_cast<int>(mean_walk * 1e6));
  RecordProperty("mean_tilt_error_urad_states", static_cast<int>(mean_states * 1e6));
  std::printf("[ gyro bias states ] mean / worst tilt error %.2f / %.2f mrad (walk only %.2f / %.2f); "
              "accelerometer bias error x %.4f y %.4f (walk only %.4f %.4f) m/s^2\n",
              mean_states * 1e3, worst_states * 1e3, mean_walk * 1e3, worst_walk * 1e3, bias_states.x(),
              bias_states.y(), bias_walk.x(), bias_walk.y());
  // AND the chain's tilt and the accelerometer bias come out better than with the walk alone
  EXPECT_LT(mean_states, 0.85 * mean_walk);  // measured 0.75
  EXPECT_LT(bias_states.head<2>().norm(), 0.5 * bias_walk.head<2>().norm());  // measured 0.25
}

TEST(AccelBiasEstimator, TheGyroBiasSigmaShrinksAsGravityShowsTheTiltRateAndCoversTheErrorLeft) {
  // GIVEN the paper IMU's accelerometer bias and the gyro bias error a still start leaves, the
  // filter with gyro-bias states started at 3e-4 rad/s (the odometry's rotation prior reads
  // this covariance: OdometryParams::gyro_bias_prior_tilt_from_filter)
  const Eigen::Vector3d &accel_bias = kPaperAccelBias, &gyro_error = kStillStartGyroError;
  AccelBiasParams params;
  params.gyro_bias_states = true;
  params.bias_random_walk_m_s2_sqrt_s = 4e-5;
  params.velocity_sigma_m_s = 0.01;
  AccelBiasParams without = params;
  without.gyro_bias_states = false;
  for (uint32_t seed : {3u, 4u, 5u}) {
    // WHEN the estimator flies the leg, the turn and the leg back
    const Flight run = fly(accel_bias, params, true, seed, gyro_error);
    const std::size_t before_turn = static_cast<std::size_t>(Lawnmower::kStill + Lawnmower::kLeg) - 3;
    const Eigen::Vector2d start = run.gyro_bias_sigma.front(), leg = run.gyro_bias_sigma[before_turn],
                          end = run.gyro_bias_sigma.back();
    std::printf("[ gyro bias sigma ] seed %u: start %.3g %.3g, before the turn %.3g %.3g, end %.3g %.3g rad/s; "
                "error at the end %.3g %.3g\n",
                seed, start.x(), start.y(), leg.x(), leg.y(), end.x(), end.y(), run.gyro_bias_error.back().x(),
                run.gyro_bias_error.back().y());
    // THEN it starts at the caller's 3e-4 rad/s...
    EXPECT_NEAR(start.x(), 3e-4, 0.3e-4);
    EXPECT_NEAR(start.y(), 3e-4, 0.3e-4);
    // ...is well below it within the first leg (the bias turns the chain's tilt away from
    // gravity at a steady rate, a straight leg shows it) and stays there to the end...
    EXPECT_LT(leg.maxCoeff(), 0.3 * start.minCoeff());  // measured 5.2e-5 rad/s
    EXPECT_LT(end.maxCoeff(), 1.05 * leg.maxCoeff());
    // ...and still covers the error left (3 sigma), so a prior built on it is not overconfident
    EXPECT_LT(std::abs(run.gyro_bias_error.back().x()), 3 * end.x()) << "seed " << seed;
    EXPECT_LT(std::abs(run.gyro_bias_error.back().y()), 3 * end.y()) << "seed " << seed;
    // AND without the states there is no gyro bias to know
    EXPECT_EQ(fly(accel_bias, without, true, seed).gyro_bias_sigma.back(), Eigen::Vector2d::Zero());
  }
}

TEST(AccelBiasEstimator, TheStartUpTiltIsLearntSoThePublishedFrameStaysTheStartUpFrame) {
  // GIVEN the same chain levelled by a biased accelerometer (30 mrad off) and the estimator
  const AccelBiasParams params = largeBiasParams();
  // WHEN it turns the chain true over a leg, a turn and the leg back
  const Flight run = fly(kLargeBias, params, true, 11);
  // THEN the start-up tilt it learnt is the levelling's error, within 1.5 mrad of 30...
  EXPECT_GT(run.start_tilt_rad.norm(), 0.025);
  EXPECT_LT((run.start_tilt_estimate_rad - run.start_tilt_rad).norm(), 1.5e-3)
      << run.start_tilt_estimate_rad.transpose() << " vs " << run.start_tilt_rad.transpose();
  // ...and the chain turned back by it stays in the start-up frame on every frame, where the
  // chain itself turned by the whole 30 mrad
  EXPECT_LT(run.tilt_error_rad.back(), 1.5e-3);
  double worst = 0;
  for (double e : run.start_frame_error_rad) worst = std::max(worst, e);
  EXPECT_LT(worst, 3e-3);
}

TEST(AccelBiasEstimator, AVelocityJumpIsRefusedAndLeavesTheEstimate) {
  // GIVEN a level vehicle at rest, the window open over 1 s of IMU data
  AccelBiasEstimator est;
  est.reset(Eigen::Matrix3d::Identity(), true, 1e-3, 3e-4);
  std::vector<ImuSample> imu;
  for (int i = 0; i <= 200; ++i) imu.push_back(ImuSample{ns(i / 200.0), Eigen::Vector3d::Zero(), -gravityW()});
  est.startWindow(Eigen::Vector3d::Zero());
  est.addInterval(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), imu, 0, ns(1.0));
  // WHEN vision reports a velocity jump of 1 m/s (a wrong match, not motion)
  const auto outcome = est.close(Eigen::Vector3d(1.0, 0, 0));
  // THEN the update is refused: no bias, no tilt correction, the window closed
  EXPECT_EQ(outcome, AccelBiasEstimator::Outcome::kRefused);
  EXPECT_EQ(est.bias(), Eigen::Vector3d::Zero());
  EXPECT_EQ(est.tiltCorrection(), Eigen::Vector3d::Zero());
  EXPECT_FALSE(est.windowOpen());
  EXPECT_GT(est.lastNis(), 16.0);
}

TEST(AccelBiasEstimator, AShortWindowStaysOpenUntilItSpansTheConfiguredTime) {
  // GIVEN a 1 s window fed 0.1 s intervals (10 Hz frames)
  AccelBiasEstimator est;
  est.reset(Eigen::Matrix3d::Identity(), true, 1e-3, 3e-4);
  std::vector<ImuSample> imu;
  for (int i = 0; i <= 400; ++i) imu.push_back(ImuSample{ns(i / 200.0), Eigen::Vector3d::Zero(), -gravityW()});
  est.startWindow(Eigen::Vector3d::Zero());
  int updated_at = -1;
  for (int k = 0; k < 15 && updated_at < 0; ++k) {
    est.addInterval(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), imu, ns(0.1 * k), ns(0.1 * (k + 1)));
    if (est.close(Eigen::Vector3d::Zero()) == AccelBiasEstimator::Outcome::kUpdated) updated_at = k;
  }
  // THEN the update comes with the tenth interval, and at rest it changes nothing
  EXPECT_EQ(updated_at, 9);
  EXPECT_LT(est.bias().norm(), 1e-6);
}

}  // namespace
}  // namespace accel_bias_estimator_test
}  // namespace seavio::imu
