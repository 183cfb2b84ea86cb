// The velocity handed over to coasting: fitted over a window of visual fixes with
// the IMU's accelerations taken out, with the covariance of that fit; and the one IMU
// interpolation the dead reckoning and the coasting covariance share.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "core/imu/coasting_covariance.hpp"
#include "core/imu/coasting_handover.hpp"
#include "core/imu/imu_interpolation.hpp"

namespace seavio::imu {
namespace coasting_handover_test {
namespace {

constexpr int64_t kFrameNs = 100'000'000;  // 10 Hz

/// A turning, accelerating path (a quarter circle of 4 m radius at 1 m/s, plus a surge and a
/// heave oscillation), position and velocity in W at `t` [s].
Eigen::Vector3d pathPosition(double t) {
  return {4 * std::sin(0.25 * t) + 0.1 * std::sin(2 * t), 4 - 4 * std::cos(0.25 * t), 0.05 * std::sin(3 * t)};
}
Eigen::Vector3d pathVelocity(double t) {
  return {std::cos(0.25 * t) + 0.2 * std::cos(2 * t), std::sin(0.25 * t), 0.15 * std::cos(3 * t)};
}

/// The interval between fixes k-1 and k as the odometry reports it: the visual displacement
/// (with position errors `e`), and the IMU increments from exact accelerations, i.e. the
/// velocity change and the displacement at zero start velocity.
VisualInterval interval(int k, const std::vector<Eigen::Vector3d>& e) {
  const double t0 = (k - 1) * 0.1, t1 = k * 0.1;
  VisualInterval v;
  v.t_ns = k * kFrameNs;
  v.displacement = pathPosition(t1) + e[static_cast<std::size_t>(k)] - pathPosition(t0) -
                   e[static_cast<std::size_t>(k - 1)];
  v.imu_dv = pathVelocity(t1) - pathVelocity(t0);
  v.imu_dp = pathPosition(t1) - pathPosition(t0) - pathVelocity(t0) * 0.1;
  return v;
}

/// Fixes 0..30: the first only anchors the window (t = 0), then the 30 intervals.
CoastingHandover thirtyFixes(const std::vector<Eigen::Vector3d>& e) {
  CoastingHandover h;
  VisualInterval anchor;
  anchor.t_ns = 0;
  h.add(anchor);
  for (int k = 1; k <= 30; ++k) h.add(interval(k, e));
  return h;
}

TEST(CoastingHandover, ExactFixesOnATurningAcceleratingPathGiveTheTrueVelocityWithNoScatter) {
  // GIVEN 30 exact fixes along a turn with surge and heave accelerations
  const std::vector<Eigen::Vector3d> e(31, Eigen::Vector3d::Zero());
  const CoastingHandover h = thirtyFixes(e);
  // WHEN the velocity is fitted over the last second
  const auto v = h.velocity({1.0, 4});
  // THEN it is the true one at the last fix, with (numerically) no uncertainty, measured on
  // average half a second before it
  ASSERT_TRUE(v.has_value());
  EXPECT_LT((v->v_W - pathVelocity(3.0)).norm(), 1e-9);
  EXPECT_LT(v->covariance.norm(), 1e-15);
  EXPECT_EQ(v->fixes, 11);
  EXPECT_NEAR(v->age_s, 0.5, 1e-9);
}

TEST(CoastingHandover, AParabolaFitMeasuresTheAccelerationTheImuMissedAndTheTrueVelocity) {
  // GIVEN exact fixes, but IMU increments short of a constant 0.2 m/s^2 in W (a 20 mrad tilt
  // error times g) along x and 0.03 m/s^2 along z
  const Eigen::Vector3d missed(0.2, 0.0, 0.03);
  CoastingHandover h;
  VisualInterval anchor;
  h.add(anchor);
  for (int k = 1; k <= 30; ++k) {
    VisualInterval v = interval(k, std::vector<Eigen::Vector3d>(31, Eigen::Vector3d::Zero()));
    v.imu_dv -= missed * 0.1;
    v.imu_dp -= 0.5 * missed * 0.01;
    h.add(v);
  }
  // WHEN the parabola is fitted over the last 2 s
  const auto v = h.velocity({2.0, 4, 10});
  // THEN it finds the missed acceleration and the true velocity at the last fix
  ASSERT_TRUE(v.has_value());
  ASSERT_TRUE(v->has_acceleration);
  EXPECT_EQ(v->fixes, 21);
  EXPECT_LT((v->acceleration_error - missed).norm(), 1e-9);
  EXPECT_LT((v->v_W - pathVelocity(3.0)).norm(), 1e-9);
  // AND the straight line alone is off by the missed acceleration over the window's age
  const auto line = h.velocity({2.0, 4, 0});
  ASSERT_TRUE(line.has_value());
  EXPECT_FALSE(line->has_acceleration);
  EXPECT_NEAR((line->v_W - pathVelocity(3.0)).norm(), missed.norm() * line->age_s, 0.02);
}

TEST(CoastingHandover, NoisyFixesGiveAVelocityWhoseSpreadTheCovarianceMatchesAndPoorFixesRaiseIt) {
  // GIVEN fixes with white position noise of 5 mm, then of 3 cm (the marginal frames at the
  // edge of a loss), over many draws
  std::mt19937 rng(7);
  for (const double sigma_p : {0.005, 0.03}) {
    std::normal_distribution<double> n(0, sigma_p);
    Eigen::Matrix3d empirical = Eigen::Matrix3d::Zero(), predicted = Eigen::Matrix3d::Zero();
    double last_frame_error2 = 0;
    const int draws = 2000;
    for (int d = 0; d < draws; ++d) {
      std::vector<Eigen::Vector3d> e(31);
      for (auto& x : e) x = {n(rng), n(rng), n(rng)};
      const CoastingHandover h = thirtyFixes(e);
      const auto v = h.velocity({1.0, 4});
      ASSERT_TRUE(v.has_value());
      const Eigen::Vector3d err = v->v_W - pathVelocity(3.0);
      empirical += err * err.transpose() / draws;
      predicted += v->covariance / draws;
      // What the odometry's own velocity would be: the last interval's displacement over dt.
      const VisualInterval last = interval(30, e);
      const Eigen::Vector3d v_last = (last.displacement - last.imu_dp) / 0.1 + last.imu_dv;
      last_frame_error2 += (v_last - pathVelocity(3.0)).squaredNorm() / draws;
    }
    // THEN the fitted covariance matches the spread of the fitted velocity per axis (20%),
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(std::sqrt(predicted(a, a) / empirical(a, a)), 1.0, 0.2) << a;
    // AND its sigma is what least squares over 11 fixes in 1 s gives (sigma_p / 1.05 s),
    EXPECT_NEAR(std::sqrt(predicted.trace() / 3), sigma_p / std::sqrt(1.1), 0.15 * sigma_p);
    // AND the velocity is several times better than the last frame's alone
    EXPECT_LT(std::sqrt(empirical.trace()), 0.25 * std::sqrt(last_frame_error2));
    std::printf("position noise %.3f m: fitted velocity sigma %.4f m/s (predicted %.4f), last frame's %.4f m/s\n",
                sigma_p, std::sqrt(empirical.trace() / 3), std::sqrt(predicted.trace() / 3),
                std::sqrt(last_frame_error2 / 3));
  }
}

TEST(CoastingHandover, ResetStartsANewWindowAndTooFewFixesGiveNothing) {
  const std::vector<Eigen::Vector3d> e(31, Eigen::Vector3d::Zero());
  CoastingHandover h;
  EXPECT_FALSE(h.velocity({1.0, 4}).has_value());
  for (int k = 1; k <= 3; ++k) h.add(interval(k, e));  // anchor + 2 intervals: 3 fixes
  EXPECT_FALSE(h.velocity({1.0, 4}).has_value());
  h.add(interval(4, e));
  EXPECT_TRUE(h.velocity({1.0, 4}).has_value());
  // Coasting broke the chain: the next fix only anchors
  h.reset();
  h.add(interval(5, e));
  EXPECT_FALSE(h.velocity({1.0, 4}).has_value());
  // A non-finite interval restarts the window too
  for (int k = 6; k <= 10; ++k) h.add(interval(k, e));
  ASSERT_TRUE(h.velocity({1.0, 4}).has_value());
  VisualInterval bad = interval(11, e);
  bad.displacement.x() = std::nan("");
  h.add(bad);
  EXPECT_FALSE(h.velocity({1.0, 4}).has_value());
  // Too few fixes inside the window (a low frame rate): no estimate, the window does not
  // stretch back in time to reach the minimum count
  CoastingHandover slow;
  for (int k = 1; k <= 30; ++k) slow.add(interval(k, e));
  EXPECT_FALSE(slow.velocity({0.15, 6}).has_value());
  const auto v = slow.velocity({0.55, 6});
  ASSERT_TRUE(v.has_value());
  EXPECT_GE(v->fixes, 6);
}

TEST(CoastingHandover, AVelocityMeasuredEarlierCarriesTheAccelerometerBiasItWasIntegratedWith) {
  // GIVEN a velocity measured with 2 cm/s per axis, 0.5 s before the start, and only an
  // accelerometer-bias error of 0.03 m/s^2, level, at rest, noiseless IMU
  ImuNoise quiet;
  quiet.gyroscope_noise_density = quiet.accelerometer_noise_density = 0;
  quiet.gyroscope_random_walk = quiet.accelerometer_random_walk = 0;
  CoastingCovariance c;
  c.start({0, 0.05, 0, 0.03});
  const double age = 0.5, sv = 0.02, b = 0.03;
  c.setMeasuredVelocity(Eigen::Matrix3d::Identity() * sv * sv, age, Eigen::Matrix3d::Identity(),
                        Eigen::Vector3d(0, 0, kGravity_m_s2));
  // THEN the velocity sigma at the start is the measured one grown by the bias over its age
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(std::sqrt(c.covariance()(3 + a, 3 + a)), std::hypot(sv, b * age), 1e-12);
  // AND after t of coasting the position error is sv t plus the bias over (age + t) minus
  // what it did before the start: b (age t + t^2 / 2), the two correlated
  const double t = 2.0;
  c.propagate(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), {}, 0,
              static_cast<int64_t>(t * 1e9), quiet);
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(std::sqrt(c.covariance()(6 + a, 6 + a)), std::hypot(sv * t, b * (age * t + 0.5 * t * t)), 1e-6);
}

/// Level IMU readings every 10 ms over [0, t_s], turning about z at `yaw_rate` [rad/s].
std::vector<ImuSample> levelSamples(double t_s, double yaw_rate) {
  std::vector<ImuSample> out;
  for (int64_t t = 0; t <= static_cast<int64_t>(t_s * 1e9); t += 10'000'000)
    out.push_back({t, Eigen::Vector3d(0, 0, yaw_rate), Eigen::Vector3d(0, 0, kGravity_m_s2)});
  return out;
}

TEST(CoastingHandover, AMeasuredAccelerationIsTheCorrectionAndItCancelsTheTiltAndTheVerticalBiasPriors) {
  // GIVEN a parabola fit's velocity and acceleration covariances, for a level body yawed by
  // 90 deg, and the usual priors (tilt 5 mrad, accelerometer bias 0.03 m/s^2)
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d Cv = Eigen::Vector3d(4e-4, 1e-4, 1e-4).asDiagonal();
  const Eigen::Matrix3d Ca = Eigen::Vector3d(9e-4, 1e-4, 1e-4).asDiagonal();
  const Eigen::Matrix3d Cva = Eigen::Vector3d(3e-4, 0, 0).asDiagonal();
  const Eigen::Vector3d da(0.2, -0.1, 0.03);
  CoastingCovariance c;
  c.start({0.005, 0.05, 0, 0.03});
  EXPECT_TRUE(c.accelerationCorrection().isZero());
  c.setMeasuredMotion(Cv, Cva, Ca, da, R);
  // THEN the dead reckoning is to add the measured acceleration
  EXPECT_TRUE(c.accelerationCorrection().isApprox(da));
  // AND the velocity error is the fit's, and the tilt and bias keep their priors (the
  // correction's error, an internal state, cancels what the tilt and the vertical bias do)
  const Matrix15d P = c.covariance();
  const Eigen::Matrix3d Pvv = P.block<3, 3>(3, 3);
  EXPECT_TRUE(Pvv.isApprox(Cv));
  EXPECT_NEAR(P(0, 0), 0.005 * 0.005, 1e-15);
  EXPECT_NEAR(P(12, 12), 0.03 * 0.03, 1e-15);
  EXPECT_TRUE(P.isApprox(P.transpose()));

  // WHEN it coasts 4 s straight with a noiseless IMU
  ImuNoise quiet;
  quiet.gyroscope_noise_density = quiet.accelerometer_noise_density = 0;
  quiet.gyroscope_random_walk = quiet.accelerometer_random_walk = 0;
  const double t = 4.0;
  CoastingCovariance straight = c;
  straight.propagate(R, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), levelSamples(t, 0.0), 0,
                     static_cast<int64_t>(t * 1e9), quiet);
  // THEN each axis' position error is the fit's plus, horizontally, the bias prior's,
  // Cv t^2 + Cva t^3 + (Ca + sigma_b^2) t^4 / 4: the tilt prior adds nothing (adding
  // it would put g 5 mrad of acceleration error on top, counting the tilt twice), nor does the
  // bias vertically (it stays vertical while the vehicle turns about the vertical)
  for (int a = 0; a < 3; ++a) {
    const double bias = a < 2 ? 0.03 * 0.03 : 0.0;
    const double expected = Cv(a, a) * t * t + Cva(a, a) * t * t * t + (Ca(a, a) + bias) * t * t * t * t / 4;
    EXPECT_NEAR(straight.covariance()(6 + a, 6 + a), expected, 1e-6 * expected) << "axis " << a;
  }
  // WHEN it turns by 90 deg over the same 4 s instead, with the 5 mrad tilt prior and without
  auto turned = [&](double tilt_sigma) {
    CoastingCovariance k;
    k.start({tilt_sigma, 0.05, 0, 0.03});
    k.setMeasuredMotion(Cv, Cva, Ca, da, R);
    k.propagate(R, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), levelSamples(t, M_PI / 2 / t), 0,
                static_cast<int64_t>(t * 1e9), quiet);
    return k.covariance()(6, 6) + k.covariance()(7, 7);
  };
  const double h_tilt = turned(0.005), h_level = turned(0.0);
  // THEN the tilt prior still adds nothing: an attitude error is a fixed rotation of the
  // estimate in W (it does not turn with the body), so its acceleration stays cancelled
  std::printf("horizontal position variance after a 4 s 90 deg turn: tilt prior 5 mrad %.4f m^2, none %.4f m^2\n",
              h_tilt, h_level);
  EXPECT_NEAR(h_tilt, h_level, 1e-3 * h_level);
  // AND without the cancelling the tilt prior alone would add (g 5 mrad t^2 / 2)^2 per
  // horizontal axis, 0.154 m^2 here: far more than the difference above
  EXPECT_GT(2 * std::pow(kGravity_m_s2 * 0.005 * t * t / 2, 2), 100 * std::abs(h_tilt - h_level));
  // AND a new outage starts without a correction
  c.start({0.005, 0.05, 3e-4, 0.03});
  EXPECT_TRUE(c.accelerationCorrection().isZero());
}

TEST(ImuInterpolation, LinearBetweenSamplesHeldBeyondTheEndsZeroWithoutSamples) {
  const std::vector<ImuSample> s = {{0, {0, 0, 1}, {0, 0, 9}}, {10, {0, 0, 3}, {1, 0, 9}}, {20, {2, 0, 3}, {1, 0, 9}}};
  const ImuSample mid = sampleAt(s, 5);
  EXPECT_EQ(mid.t_ns, 5);
  EXPECT_DOUBLE_EQ(mid.gyro_rad_s.z(), 2.0);
  EXPECT_DOUBLE_EQ(mid.accel_m_s2.x(), 0.5);
  EXPECT_DOUBLE_EQ(sampleAt(s, 10).gyro_rad_s.z(), 3.0);  // on a sample: that sample
  EXPECT_DOUBLE_EQ(sampleAt(s, 15).gyro_rad_s.x(), 1.0);
  EXPECT_DOUBLE_EQ(sampleAt(s, -100).gyro_rad_s.z(), 1.0);
  EXPECT_DOUBLE_EQ(sampleAt(s, 100).gyro_rad_s.x(), 2.0);
  const ImuSample none = sampleAt({}, 3);
  EXPECT_EQ(none.t_ns, 3);
  EXPECT_TRUE(none.gyro_rad_s.isZero() && none.accel_m_s2.isZero());
}

}  // namespace
}  // namespace coasting_handover_test
}  // namespace seavio::imu
