// Coasting at 1 Hz (core/imu/coasting_leak.hpp): the acceleration the IMU misses,
// measured from the innovations of several recent fixes that agree, corrects the coasted
// frames; a poor fix among them does not; fixes that disagree correct nothing and widen the
// coasting covariance instead.
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "core/imu/coasting_covariance.hpp"
#include "core/imu/coasting_leak.hpp"
#include "core/imu/imu_noise.hpp"

namespace seavio::imu {
namespace coasting_leak_test {
namespace {

constexpr int64_t kSecondNs = 1'000'000'000;

/// The odometry's loop (odometry.cpp) in W at 1 Hz: the vehicle holds `v_true`, the IMU reads
/// its acceleration minus `leak` (tilt x g, accelerometer bias). Each visual fix sets the
/// position (plus `noise[k]`, or `poor[k]` for a poor fix) and corrects the velocity by the
/// miss over dt; then `coasted` frames without vision, either on the bare prediction or
/// corrected as odometry.cpp does with the estimate. Returns the final position error [m].
struct Loop {
  Eigen::Vector3d v_true{1.5, 0.2, 0.0};
  Eigen::Vector3d leak{0.3, -0.12, 0.05};
  double dt = 1.0;
  int fixes = 12;
  int coasted = 11;
  std::vector<Eigen::Vector3d> fix_error;  ///< per fix, zero if empty

  /// The last fix's innovation (for the single-fix correction that was tried and not kept).
  Eigen::Vector3d last_innovation = Eigen::Vector3d::Zero();

  double run(CoastingLeak& estimator, int mode, std::optional<LeakEstimate>* used = nullptr) {
    // mode 0: bare prediction; 1: this estimator; 2: the last fix's miss x k (not kept).
    Eigen::Vector3d p = Eigen::Vector3d::Zero(), v = v_true + Eigen::Vector3d(0.1, 0, 0);
    Eigen::Vector3d p_true = Eigen::Vector3d::Zero();
    int64_t t = 0;
    for (int k = 1; k <= fixes; ++k) {
      t += static_cast<int64_t>(dt * kSecondNs);
      p_true += v_true * dt;
      const Eigen::Vector3d p_pred = p + v * dt - 0.5 * leak * dt * dt;
      const Eigen::Vector3d v_pred = v - leak * dt;
      const Eigen::Vector3d e =
          fix_error.empty() ? Eigen::Vector3d::Zero() : fix_error[static_cast<std::size_t>(k - 1)];
      const Eigen::Vector3d p_vision = p_true + e;
      last_innovation = p_vision - p_pred;
      estimator.fix(last_innovation, dt, t);
      v = v_pred + last_innovation / dt;
      p = p_vision;
    }
    const Eigen::Vector3d fix_error_last = p - p_true;
    std::optional<LeakEstimate> leak_hat = estimator.estimate(t + kSecondNs, {});
    if (used) *used = leak_hat;
    Eigen::Vector3d da = Eigen::Vector3d::Zero();
    for (int k = 1; k <= coasted; ++k) {
      p_true += v_true * dt;
      p += v * dt - 0.5 * leak * dt * dt;
      v -= leak * dt;
      if (mode == 1 && leak_hat && leak_hat->consistent) {
        if (k == 1) {
          const Eigen::Vector3d dv = leak_hat->acceleration_W * leak_hat->velocity_lag_s;
          p += dv * dt;
          v += dv;
          da = leak_hat->acceleration_W;
        }
        p += 0.5 * da * dt * dt;
        v += da * dt;
      } else if (mode == 2) {
        p += last_innovation * k;
      }
    }
    return (p - p_true - fix_error_last).norm();
  }
};

TEST(CoastingLeak, ElevenCoastedFramesAtOneHertzWithAnAccelerometerBiasMissByATenthOfTheBarePrediction) {
  // GIVEN a 1 Hz survey whose IMU misses 0.33 m/s^2 (an accelerometer bias), fixes with 1 cm noise
  Loop loop;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 0.01);
  for (int k = 0; k < loop.fixes; ++k) loop.fix_error.emplace_back(n(rng), n(rng), n(rng));
  // WHEN 11 frames in a row coast, on the bare prediction and with the leak the fixes agree on
  CoastingLeak bare, corrected;
  const double bare_error = loop.run(bare, 0);
  std::optional<LeakEstimate> leak;
  const double corrected_error = loop.run(corrected, 1, &leak);
  // THEN the bare prediction misses by sum k x leak x dt^2 (~22 m), the corrected one by what
  // the fixes' noise leaves of the estimate, and the estimate is the leak
  ASSERT_TRUE(leak.has_value());
  EXPECT_TRUE(leak->consistent);
  EXPECT_NEAR((leak->acceleration_W - loop.leak).norm(), 0.0, 0.06);
  EXPECT_NEAR(bare_error, 66 * loop.leak.norm(), 0.1 * 66 * loop.leak.norm());
  EXPECT_LT(corrected_error, 0.1 * bare_error);
}

TEST(CoastingLeak, APoorLastFixDoesNotThrowTheCorrectionOff) {
  // GIVEN the same survey with a poor step (1.5 m off: few inliers) at the last fix but one; the
  // chain keeps that error, so it shows in two innovations: +1.5 m, and -1.5 m in the last one
  Loop loop;
  loop.fix_error.assign(static_cast<std::size_t>(loop.fixes), Eigen::Vector3d::Zero());
  for (int k = loop.fixes - 2; k < loop.fixes; ++k)
    loop.fix_error[static_cast<std::size_t>(k)] = Eigen::Vector3d(1.2, -0.9, 0.0);
  // WHEN it coasts with the estimator and with the last fix's miss applied k times
  CoastingLeak corrected, single;
  std::optional<LeakEstimate> leak;
  const double corrected_error = loop.run(corrected, 1, &leak);
  const double single_fix_error = loop.run(single, 2);
  const double bare_error = loop.run(single, 0);
  // THEN the three clean fixes of the last five agree, the two the poor step touched do not, and
  // the coasting ends within decimetres, where the single-fix correction is worse than none
  ASSERT_TRUE(leak.has_value());
  EXPECT_TRUE(leak->consistent);
  EXPECT_EQ(leak->used, 5);
  EXPECT_EQ(leak->agreeing, 3);
  EXPECT_LT((leak->acceleration_W - loop.leak).norm(), 0.01);
  EXPECT_LT(corrected_error, 0.1);
  EXPECT_GT(single_fix_error, bare_error);
}

TEST(CoastingLeak, FixesThatDisagreeCorrectNothingButTheCovarianceCoversTheLeak) {
  // GIVEN steady fixes whose innovations point every which way (0.4 m/s^2 each)
  CoastingLeak leak;
  const double dt = 1.0;
  leak.fix(Eigen::Vector3d::Zero(), dt, 0);  // anchors: the next fix is steady
  const std::vector<Eigen::Vector3d> misses = {{0.4, 0, 0}, {0, 0.4, 0}, {-0.4, 0, 0}, {0, -0.4, 0}, {0.28, 0.28, 0}};
  for (std::size_t k = 0; k < misses.size(); ++k)
    leak.fix(misses[k] * dt * dt, dt, static_cast<int64_t>(k + 1) * kSecondNs);
  // WHEN a loss starts
  const std::optional<LeakEstimate> e = leak.estimate(6 * kSecondNs, {});
  // THEN there is no correction, and the covariance is the leak's second moment (0.08 per
  // horizontal axis, 0.4^2 / 2)
  ASSERT_TRUE(e.has_value());
  EXPECT_FALSE(e->consistent);
  EXPECT_EQ(e->acceleration_W, Eigen::Vector3d::Zero());
  EXPECT_NEAR(e->covariance(0, 0), 0.4 * 0.4 / 2, 0.01);
  EXPECT_NEAR(e->covariance(1, 1), 0.4 * 0.4 / 2, 0.01);
  EXPECT_DOUBLE_EQ(e->velocity_lag_s, 0.5);
}

TEST(CoastingLeak, TheCoastingCovarianceGrowsWithAnUncorrectedLeak) {
  // GIVEN the leak of an uncorrected 1 Hz coasting (0.48 m/s^2, paper-snow's 0.48 m per step)
  // and 18 frames in a row coasted on the bare prediction (the run at paper-snow frame 2760)
  const Eigen::Vector3d leak_W(0.4, -0.27, 0.0);
  const double lag = 0.5, seconds = 18;
  Eigen::Vector3d dv = leak_W * lag, dp = Eigen::Vector3d::Zero();
  for (int k = 0; k < 18; ++k) {
    dp += dv + 0.5 * leak_W;
    dv += leak_W;
  }
  const double real_error = dp.norm();  // ~ 0.48 x (1 + ... + 18) = 82 m
  const ImuNoise noise;
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  const auto sigma = [&](CoastingCovariance& c) {
    c.propagate(R, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), {}, 0, static_cast<int64_t>(seconds * kSecondNs),
                noise);
    return std::sqrt(c.poseCovariance(R).bottomRightCorner<3, 3>().trace());
  };
  // WHEN the covariance starts from the priors alone, and with the leak the fixes measured
  // (disagreeing, so uncorrected: the second moment of their misses)
  CoastingCovariance prior, measured;
  const CoastingStart start;
  prior.start(start);
  measured.start(start);
  const Eigen::Matrix3d Ca = leak_W * leak_W.transpose();
  measured.setMeasuredMotion(Eigen::Matrix3d::Identity() * std::pow(start.velocity_sigma_m_s, 2) + lag * lag * Ca,
                             lag * Ca, Ca, Eigen::Vector3d::Zero(), R);
  // THEN the real error is beyond 3 sigma of the priors, and within 3 sigma of the measured leak
  // (which is not inflated beyond it either)
  const double sigma_prior = sigma(prior), sigma_measured = sigma(measured);
  EXPECT_LT(3 * sigma_prior, real_error);
  EXPECT_GT(3 * sigma_measured, real_error);
  EXPECT_LT(sigma_measured, 1.5 * real_error);
}

TEST(CoastingLeak, NothingAtTenHertzNorAfterALossOrReset) {
  CoastingLeak leak;
  for (int k = 0; k < 10; ++k) leak.fix(Eigen::Vector3d(0.003, 0, 0), 0.1, k * kSecondNs / 10);
  EXPECT_FALSE(leak.estimate(kSecondNs, {}).has_value());  // 10 Hz: the handover fit's job
  for (int k = 0; k < 6; ++k) leak.fix(Eigen::Vector3d(0.3, 0, 0), 1.0, (2 + k) * kSecondNs);
  ASSERT_TRUE(leak.estimate(8 * kSecondNs, {}).has_value());
  EXPECT_NEAR(leak.estimate(8 * kSecondNs, {})->acceleration_W.x(), 0.3, 1e-12);
  EXPECT_FALSE(leak.estimate(60 * kSecondNs, {}).has_value());  // stale
  leak.coast();
  EXPECT_FALSE(leak.estimate(9 * kSecondNs, {}).has_value());  // the lost frame has no lag to undo
  leak.fix(Eigen::Vector3d(5.0, 0, 0), 1.0, 10 * kSecondNs);   // after the loss: not steady, not kept
  EXPECT_NEAR(leak.estimate(10 * kSecondNs, {})->acceleration_W.x(), 0.3, 1e-12);
  leak.reset();
  EXPECT_FALSE(leak.estimate(10 * kSecondNs, {}).has_value());
}

}  // namespace
}  // namespace coasting_leak_test
}  // namespace seavio::imu
