#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "core/imu/imu_integrator.hpp"

namespace seavio::imu {
namespace imu_integrator_test {
namespace {

// An analytic trajectory: constant body rate, smooth position.
struct Analytic {
  Eigen::Vector3d w_B{0.05, -0.03, 0.2};
  Eigen::Matrix3d R(double t) const { return se3::expSO3(w_B * t); }
  Eigen::Vector3d p(double t) const { return {std::sin(t), 0.5 * t * t, 0.3 * std::cos(2 * t)}; }
  Eigen::Vector3d v(double t) const { return {std::cos(t), t, -0.6 * std::sin(2 * t)}; }
  Eigen::Vector3d a(double t) const { return {-std::sin(t), 1.0, -1.2 * std::cos(2 * t)}; }
  ImuSample sample(double t) const {
    return ImuSample{static_cast<int64_t>(std::llround(t * 1e9)), w_B, R(t).transpose() * (a(t) - gravityW())};
  }
  NavState state(double t) const {
    NavState s;
    s.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    s.T_W_B.linear() = R(t);
    s.T_W_B.translation() = p(t);
    s.v_W = v(t);
    return s;
  }
};

TEST(ImuIntegrator, NoiselessIntegrationReproducesTheTrajectory) {
  // GIVEN 1 s of exact 200 Hz IMU data from an analytic trajectory
  const Analytic traj;
  std::vector<ImuSample> samples;
  for (int i = 0; i <= 200; ++i) samples.push_back(traj.sample(i / 200.0));
  // WHEN propagated from the true start state
  const ImuPropagation out = propagate(traj.state(0), Matrix9d::Zero(), samples, samples.back().t_ns, ImuNoise{});
  // THEN position, velocity and attitude agree with the analytic end state
  const NavState truth = traj.state(1.0);
  EXPECT_LT((out.state.T_W_B.translation() - truth.T_W_B.translation()).norm(), 1e-4);
  EXPECT_LT((out.state.v_W - truth.v_W).norm(), 1e-4);
  EXPECT_LT(se3::angle(Eigen::Isometry3d(out.state.T_W_B.rotation().transpose() * truth.T_W_B.rotation())), 1e-9);
  EXPECT_EQ(out.samples_used, 199);
  EXPECT_NEAR(out.largest_gap_s, 0.005, 1e-9);
}

TEST(ImuIntegrator, EndTimeBetweenSamplesInterpolates) {
  const Analytic traj;
  std::vector<ImuSample> samples;
  for (int i = 0; i <= 40; ++i) samples.push_back(traj.sample(i / 200.0));
  const int64_t t_end = static_cast<int64_t>(0.1234 * 1e9);
  const ImuPropagation out = propagate(traj.state(0), Matrix9d::Zero(), samples, t_end, ImuNoise{});
  EXPECT_LT((out.state.T_W_B.translation() - traj.p(0.1234)).norm(), 1e-6);
  EXPECT_EQ(out.state.t_ns, t_end);
}

TEST(ImuIntegrator, BiasIsSubtracted) {
  const Analytic traj;
  const Eigen::Vector3d bg(0.01, -0.02, 0.005), ba(0.1, 0.05, -0.2);
  std::vector<ImuSample> samples;
  for (int i = 0; i <= 100; ++i) {
    ImuSample s = traj.sample(i / 100.0);
    s.gyro_rad_s += bg;
    s.accel_m_s2 += ba;
    samples.push_back(s);
  }
  NavState start = traj.state(0);
  start.gyro_bias_rad_s = bg;
  start.accel_bias_m_s2 = ba;
  const ImuPropagation out = propagate(start, Matrix9d::Zero(), samples, samples.back().t_ns, ImuNoise{});
  EXPECT_LT((out.state.T_W_B.translation() - traj.p(1.0)).norm(), 5e-4);
}

TEST(ImuIntegrator, CovarianceMatchesMonteCarloSpread) {
  // GIVEN a vehicle at rest and a noisy IMU
  ImuNoise noise;
  noise.gyroscope_noise_density = 2e-3;
  noise.accelerometer_noise_density = 2e-2;
  noise.gyroscope_random_walk = 0;
  noise.accelerometer_random_walk = 0;
  const double rate = 200, dt = 1.0 / rate;
  std::mt19937 rng(42);
  std::normal_distribution<double> n01;
  NavState start;
  const int runs = 300, steps = 200;
  std::vector<double> px;
  Matrix9d predicted = Matrix9d::Zero();
  for (int r = 0; r < runs; ++r) {
    std::vector<ImuSample> samples;
    for (int i = 0; i <= steps; ++i) {
      ImuSample s;
      s.t_ns = static_cast<int64_t>(std::llround(i * dt * 1e9));
      for (int k = 0; k < 3; ++k) {
        s.gyro_rad_s[k] = n01(rng) * noise.gyroscope_noise_density / std::sqrt(dt);
        s.accel_m_s2[k] = n01(rng) * noise.accelerometer_noise_density / std::sqrt(dt);
      }
      s.accel_m_s2.z() += kGravity_m_s2;
      samples.push_back(s);
    }
    const ImuPropagation out = propagate(start, Matrix9d::Zero(), samples, samples.back().t_ns, noise);
    px.push_back(out.state.T_W_B.translation().x());
    predicted = out.covariance;
  }
  double var = 0;
  for (double x : px) var += x * x;
  var /= runs;
  // WHEN the empirical spread is compared with the propagated covariance
  // THEN they agree within the sampling error of 300 runs (and the midpoint averaging, which
  // smooths white noise, makes the prediction conservative by at most a small factor)
  const double ratio = std::sqrt(var / predicted(6, 6));
  EXPECT_GT(ratio, 0.5);
  EXPECT_LT(ratio, 1.3);
}

TEST(ImuIntegrator, AttitudeFromAccelerometerRecoversRollPitch) {
  const Eigen::Matrix3d R_W_B = (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX())).toRotationMatrix();
  std::vector<ImuSample> samples(10);
  for (auto& s : samples) s.accel_m_s2 = R_W_B.transpose() * -gravityW();
  const auto R = attitudeFromAccelerometer(samples);
  ASSERT_TRUE(R.has_value());
  // Gravity direction matches, yaw is zero.
  EXPECT_LT((*R * samples[0].accel_m_s2 - Eigen::Vector3d(0, 0, kGravity_m_s2)).norm(), 1e-9);
  EXPECT_NEAR(std::atan2((*R)(1, 0), (*R)(0, 0)), 0.0, 1e-9);
  // An accelerating vehicle is refused.
  for (auto& s : samples) s.accel_m_s2 *= 1.5;
  EXPECT_FALSE(attitudeFromAccelerometer(samples).has_value());
}

TEST(ImuIntegrator, NoSamplesExtrapolatesAndGrowsUncertainty) {
  NavState start;
  start.v_W = {1, 0, 0};
  const ImuPropagation out = propagate(start, Matrix9d::Zero(), {}, 500'000'000, ImuNoise{});
  EXPECT_NEAR(out.state.T_W_B.translation().x(), 0.5, 1e-12);
  EXPECT_GT(out.covariance(6, 6), 1.0);
  EXPECT_NEAR(out.largest_gap_s, 0.5, 1e-12);
}

}  // namespace
}  // namespace imu_integrator_test
}  // namespace seavio::imu
