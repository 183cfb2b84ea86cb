// The tilt rates of the gyro bias from gravity: over windows of visual tracking the
// accelerometer, against vision's acceleration, sees the chain's tilt drift; a constant
// accelerometer bias must not enter, nor must the vehicle's own accelerations, and a turn
// (which rotates the accelerometer bias in W) must stop the comparison.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "core/imu/gravity_bias_observer.hpp"
#include "core/imu/imu_integrator.hpp"

namespace seavio::imu {
namespace gravity_bias_observer_test {
namespace {

struct Flight {
  Eigen::Vector3d bias_error_B = Eigen::Vector3d::Zero();  ///< true - estimated gyro bias [rad/s]
  Eigen::Vector3d accel_bias_B = Eigen::Vector3d::Zero();  ///< [m/s^2]
  double surge_amplitude_m = 0;   ///< the vehicle surges back and forth (vision measures it)
  double yaw_rate_rad_s = 0;      ///< a steady turn
  double position_noise_m = 0;    ///< vision's position noise per frame
  /// From this time on a map correction moves the chain at every frame [s], by a random turn
  /// and shift of these sigmas (zero mean: the map pulls the chain back and forth)
  double correction_from_s = 1e9;
  double correction_sigma_rad = 0, correction_sigma_m = 0;
  bool observer_told = true;      ///< moveChain() called with each correction
};

/// 30 s at 10 Hz, 1 m/s, level; the chain's attitude drifts by the bias error, the true one
/// only yaws. Returns every rate the observer reports.
std::vector<Eigen::Vector3d> fly(const Flight& f) {
  GravityBiasObserver obs;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  const auto truePose = [&](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(f.yaw_rate_rad_s * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(t + f.surge_amplitude_m * std::sin(0.7 * t), 0, 0);
    return T;
  };
  const auto trueVelocity = [&](double t) {
    return Eigen::Vector3d(1.0 + 0.7 * f.surge_amplitude_m * std::cos(0.7 * t), 0, 0);
  };
  // The chain: the true attitude turned by the integrated bias error (body frame, so it turns
  // with the vehicle's heading).
  const auto chainR = [&](double t) {
    const int steps = 200;
    Eigen::Matrix3d R_err = Eigen::Matrix3d::Identity();
    for (int i = 0; i < steps; ++i) {
      const double s = (i + 0.5) * t / steps;
      R_err = se3::expSO3(truePose(s).linear() * f.bias_error_B * (t / steps)) * R_err;
    }
    return Eigen::Matrix3d(R_err * truePose(t).linear());
  };
  std::vector<Eigen::Vector3d> rates;
  Eigen::Vector3d p_prev = truePose(0).translation();
  // Every correction so far (corrected <- odometry world), as the odometry chains them.
  Eigen::Isometry3d C = Eigen::Isometry3d::Identity();
  for (int k = 1; k <= 300; ++k) {
    const double t0 = 0.1 * (k - 1), t1 = 0.1 * k, tm = 0.5 * (t0 + t1);
    if (t1 > f.correction_from_s) {
      // This frame's pose comes out of the map moved; the interval's start follows it.
      Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
      delta.linear() = se3::expSO3(f.correction_sigma_rad * Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
      delta.translation() = f.correction_sigma_m * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      C = delta * C;
      if (f.observer_told) {
        obs.moveChain(delta);
        p_prev = delta * p_prev;
      }
    }
    // Mean specific force over the interval in the true body frame: the mean acceleration
    // minus gravity, plus the accelerometer bias.
    const Eigen::Vector3d a_mean = (trueVelocity(t1) - trueVelocity(t0)) / 0.1;
    const Eigen::Vector3d f_B = truePose(tm).linear().transpose() * (a_mean - gravityW()) + f.accel_bias_B;
    Eigen::Vector3d p1 = truePose(t1).translation();
    p1 += f.position_noise_m * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    p1 = C * p1;
    const auto rate = obs.add(static_cast<int64_t>(std::llround(t0 * 1e9)), p_prev,
                              static_cast<int64_t>(std::llround(t1 * 1e9)), p1, C.linear() * chainR(tm), f_B,
                              C.linear() * chainR(t1));
    if (rate) rates.push_back(*rate);
    p_prev = p1;
  }
  return rates;
}

TEST(GravityBiasObserver, MeasuresTheTiltRateOfTheChainAndNotTheAccelerometerBias) {
  // GIVEN a chain whose gyro bias is off by 0.2 mrad/s in roll and -0.3 in pitch (and 0.5 in
  // heading, which gravity cannot see) and an accelerometer bias of 0.03 m/s^2 (3 mrad of tilt)
  Flight f;
  f.bias_error_B = Eigen::Vector3d(2e-4, -3e-4, 5e-4);
  f.accel_bias_B = Eigen::Vector3d(0.03, -0.02, 0.01);
  // WHEN the observer compares window pairs of 2 s
  const std::vector<Eigen::Vector3d> rates = fly(f);
  // THEN after three windows every new window reports the tilt part of the bias error
  ASSERT_GE(rates.size(), 10u);
  for (const Eigen::Vector3d& r : rates) {
    EXPECT_NEAR(r.x(), 2e-4, 1e-5);
    EXPECT_NEAR(r.y(), -3e-4, 1e-5);
    EXPECT_NEAR(r.z(), 0.0, 1e-6);  // heading: not observed by gravity
  }
}

TEST(GravityBiasObserver, NeitherTheAccelerometerBiasNorTheVehiclesAccelerationsReportARate) {
  // GIVEN a correct gyro bias, an accelerometer bias of 0.05 m/s^2 (5 mrad if taken for tilt)
  // and a vehicle surging +-0.3 m about its cruise (0.15 m/s^2, which vision measures)
  Flight f;
  f.accel_bias_B = Eigen::Vector3d(0.05, 0.05, 0.0);
  f.surge_amplitude_m = 0.3;
  const auto rms = [](const std::vector<Eigen::Vector3d>& rates) {
    double sum2 = 0;
    for (const Eigen::Vector3d& r : rates) sum2 += r.squaredNorm();
    return std::sqrt(sum2 / static_cast<double>(std::max<std::size_t>(rates.size(), 1)));
  };
  // THEN with exact positions no rate is reported (the piecewise-constant specific force over
  // 0.1 s intervals leaves 2e-6 rad/s)
  const std::vector<Eigen::Vector3d> exact = fly(f);
  ASSERT_GE(exact.size(), 10u);
  EXPECT_LT(rms(exact), 1e-5);  // not taking the surge out would give ~1e-2 rad/s
  // AND with 0.5 mm of position noise per frame only vision's noise is: the difference of two
  // pair residuals 2 s apart is p3 - 3 p2 + 3 p1 - p0 over (2 s)^3 g, 2.9e-5 rad/s rms
  f.position_noise_m = 5e-4;
  const std::vector<Eigen::Vector3d> noisy = fly(f);
  ASSERT_GE(noisy.size(), 10u);
  EXPECT_LT(rms(noisy), 5e-5);
}

TEST(GravityBiasObserver, FollowsTheChainThroughMapCorrections) {
  // GIVEN the biased chain of the first test, and from 5 s on a map correction at every frame
  // (as the global map makes at 1 Hz once the survey is back over mapped ground) of 0.3 mrad
  // and 1 cm (sigma per axis; the chain wanders by ~5 mrad over the flight)
  Flight f;
  f.bias_error_B = Eigen::Vector3d(2e-4, -3e-4, 5e-4);
  f.accel_bias_B = Eigen::Vector3d(0.03, -0.02, 0.01);
  f.correction_from_s = 5.0;
  f.correction_sigma_rad = 3e-4;
  f.correction_sigma_m = 0.01;
  // WHEN the observer is told of each correction
  const std::vector<Eigen::Vector3d> rates = fly(f);
  // THEN it keeps reporting the chain's own tilt rate, as without corrections: the windows
  // chain on in the corrected frame and the corrections' tilt is not taken for a bias
  ASSERT_GE(rates.size(), 10u);
  for (const Eigen::Vector3d& r : rates) {
    EXPECT_NEAR(r.x(), 2e-4, 1e-5);
    EXPECT_NEAR(r.y(), -3e-4, 1e-5);
  }
  // AND not told, the corrections' tilt and shifts would be reported as the bias
  f.observer_told = false;
  double worst = 0;
  for (const Eigen::Vector3d& r : fly(f)) worst = std::max(worst, (r - Eigen::Vector3d(2e-4, -3e-4, 0)).norm());
  std::printf("[ gravity  ] not told of the corrections: worst rate error %.2g rad/s\n", worst);
  EXPECT_GT(worst, 1e-3);
}

TEST(GravityBiasObserver, ATurnStopsTheComparison) {
  // GIVEN a steady turn of 0.1 rad/s (0.2 rad per window, over the 0.05 rad allowed) with an
  // accelerometer bias, which the turn rotates in W
  Flight f;
  f.accel_bias_B = Eigen::Vector3d(0.05, 0.0, 0.0);
  f.yaw_rate_rad_s = 0.1;
  // THEN nothing is reported
  EXPECT_TRUE(fly(f).empty());
  // AND a gap in the intervals (vision lost) starts the windows afresh: no rate from before it
  const auto reported = [](bool gap) {
    GravityBiasObserver obs;
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    const Eigen::Vector3d f_B = -gravityW();
    int n = 0;
    for (int k = 1; k <= 100; ++k) {
      if (gap && k == 50) continue;  // one interval missing
      const Eigen::Vector3d p0(0.1 * (k - 1), 0, 0), p1(0.1 * k, 0, 0);
      n += obs.add(100'000'000LL * (k - 1), p0, 100'000'000LL * k, p1, I, f_B, I).has_value();
    }
    return n;
  };
  // 5 windows of 2 s give 3 rates; with the gap each side has only 2 windows
  EXPECT_EQ(reported(false), 3);
  EXPECT_EQ(reported(true), 0);
}

TEST(GravityBiasObserver, AWindowSpansAtLeastItsMinimumOfFrameIntervals) {
  // GIVEN level flight at 1 m/s with no error, tracked at a frame interval of dt_s
  const auto firstRateAt = [](double dt_s, int min_intervals) {
    GravityBiasObserverParams params;
    params.window_s = 1.0;
    params.min_intervals = min_intervals;
    GravityBiasObserver obs(params);
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    const auto ns = [&](int k) { return static_cast<int64_t>(std::llround(k * dt_s * 1e9)); };
    for (int k = 1; k <= 1000; ++k) {
      const Eigen::Vector3d p0(dt_s * (k - 1), 0, 0), p1(dt_s * k, 0, 0);
      const auto rate = obs.add(ns(k - 1), p0, ns(k), p1, I, -gravityW(), I);
      if (rate) {
        EXPECT_LT(rate->norm(), 1e-9);
        return k;
      }
    }
    return -1;
  };
  // THEN a rate needs three windows: at 10 Hz 1 s each (10 intervals) either way; at 1 Hz one
  // interval each, or two with min_intervals 2 (the 2 s windows 1 Hz has always had)
  EXPECT_EQ(firstRateAt(0.1, 1), 30);
  EXPECT_EQ(firstRateAt(0.1, 2), 30);
  EXPECT_EQ(firstRateAt(1.0, 1), 3);
  EXPECT_EQ(firstRateAt(1.0, 2), 6);
}

}  // namespace
}  // namespace gravity_bias_observer_test
}  // namespace seavio::imu
