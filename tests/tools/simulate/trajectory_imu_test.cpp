// GIVEN the short survey, WHEN its IMU is simulated, THEN integrating it reproduces the ground
// truth exactly (noiseless) or within the noise model (noisy).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/common/se3.hpp"
#include "tools/simulate/imu_simulator.hpp"
#include "tools/simulate/seafloor.hpp"
#include "tools/simulate/trajectory.hpp"

namespace seavio::simulate {
namespace {

struct Integrated {
  Eigen::Matrix3d R;
  Eigen::Vector3d v, p;
};

/// Integrates samples [k0, k1] from the ground-truth state at k0, removing the ground-truth
/// biases: trapezoidal velocity, matching position, midpoint rotation.
Integrated integrate(const ImuSequence& seq, size_t k0, size_t k1) {
  const Eigen::Vector3d g(0, 0, -imu::kGravity_m_s2);
  Integrated s{seq.ground_truth[k0].T_W_B.rotation(), seq.ground_truth[k0].v_W,
               seq.ground_truth[k0].T_W_B.translation()};
  for (size_t k = k0; k < k1; ++k) {
    const double dt = (seq.samples[k + 1].t_ns - seq.samples[k].t_ns) * 1e-9;
    const auto& a = seq.samples[k];
    const auto& b = seq.samples[k + 1];
    const auto& ga = seq.ground_truth[k];
    const auto& gb = seq.ground_truth[k + 1];
    const Eigen::Vector3d w = 0.5 * (a.gyro_rad_s - ga.gyro_bias_rad_s + b.gyro_rad_s - gb.gyro_bias_rad_s);
    const Eigen::Matrix3d R1 = s.R * se3::expSO3(w * dt);
    const Eigen::Vector3d a0 = s.R * (a.accel_m_s2 - ga.accel_bias_m_s2) + g;
    const Eigen::Vector3d a1 = R1 * (b.accel_m_s2 - gb.accel_bias_m_s2) + g;
    s.p += s.v * dt + dt * dt / 6.0 * (2 * a0 + a1);
    s.v += 0.5 * dt * (a0 + a1);
    s.R = R1;
  }
  return s;
}

class TrajectoryImuTest : public ::testing::Test {
 protected:
  SimConfig config = presetConfig("short-plain");
  ReliefField relief{config.seafloor, config.seed};
  Trajectory traj{config.trajectory, relief, 60.0};
};

TEST_F(TrajectoryImuTest, StartsAtRestThenAcceleratesAtAltitude) {
  const BodyState s0 = traj.at(0.5);
  EXPECT_LT(s0.v_W.norm(), 1e-12);
  EXPECT_LT(s0.omega_B.norm(), 1e-12);
  const ImuSample m = ImuSimulator::idealSample(s0, kStartTimeNs);
  EXPECT_NEAR(m.accel_m_s2.z(), imu::kGravity_m_s2, 1e-9);  // at rest: +1 g on body z
  EXPECT_NEAR(m.accel_m_s2.head<2>().norm(), 0.0, 1e-9);
  const BodyState s1 = traj.at(20.0);
  EXPECT_NEAR(s1.v_W.head<2>().norm(), config.trajectory.speed_m_s, 1e-9);
  const double floor = relief.eval(s1.p_W.x(), s1.p_W.y()).h;
  EXPECT_NEAR(s1.p_W.z() - floor, config.trajectory.altitude_m, 1e-9);
}

TEST_F(TrajectoryImuTest, DerivativesMatchFiniteDifferences) {
  const double h = 1e-4;
  for (double t : {3.0, 4.5, 12.0, 33.0, 38.0, 41.0, 55.0}) {  // ramp, legs and the turn
    const BodyState a = traj.at(t - h), s = traj.at(t), b = traj.at(t + h);
    EXPECT_LT(((b.p_W - a.p_W) / (2 * h) - s.v_W).norm(), 1e-6) << t;
    EXPECT_LT(((b.v_W - a.v_W) / (2 * h) - s.a_W).norm(), 1e-5) << t;
    const Eigen::Vector3d w = se3::logSO3(a.R_W_B.transpose() * b.R_W_B) / (2 * h);
    EXPECT_LT((w - s.omega_B).norm(), 1e-6) << t;
  }
}

TEST_F(TrajectoryImuTest, MakesOneHalfTurnBetweenTwoLegs) {
  const double yaw0 = std::atan2(traj.at(15).v_W.y(), traj.at(15).v_W.x());
  const double yaw1 = std::atan2(traj.at(58).v_W.y(), traj.at(58).v_W.x());
  EXPECT_NEAR(std::abs(std::remainder(yaw1 - yaw0, 2 * M_PI)), M_PI, 1e-6);
  const double lateral = std::abs(traj.at(58).p_W.y() - traj.at(15).p_W.y());
  EXPECT_NEAR(lateral, config.trajectory.leg_spacing_m, 0.02 * config.trajectory.leg_spacing_m);
}

TEST_F(TrajectoryImuTest, UnlimitedTurnRateTurnsFastAndStaysSmooth) {
  TrajectoryConfig fast = config.trajectory;
  fast.unlimited_turn_rate = true;
  const Trajectory t(fast, relief, 70.0);
  double peak = 0, peak_limited = 0;
  for (double s = 0; s < 70; s += 0.05) {
    peak = std::max(peak, std::abs(t.at(s).omega_B.z()));
    peak_limited = std::max(peak_limited, std::abs(traj.at(s).omega_B.z()));
  }
  EXPECT_GT(peak, 0.9);
  EXPECT_LE(peak_limited, config.trajectory.max_yaw_rate_rad_s + 0.02);  // sway adds a little
  for (double s = 38.0; s < 60.0; s += 0.37) {
    const BodyState a = t.at(s - 1e-4), b = t.at(s + 1e-4), m = t.at(s);
    EXPECT_LT(((b.v_W - a.v_W) / 2e-4 - m.a_W).norm(), 1e-4) << s;
  }
}

TEST_F(TrajectoryImuTest, NoiselessImuIntegratesBackToGroundTruth) {
  std::mt19937 rng(3);
  const ImuSimulator sim(config.imu, 0.0, 0.0);
  const ImuSequence seq = sim.simulate(traj, 50.0, rng, /*noiseless=*/true);
  const size_t per_s = static_cast<size_t>(config.imu.rate_hz);
  for (double start_s : {1.5, 3.0, 20.0, 36.0, 40.0}) {  // includes start-up and the turn
    const auto k0 = static_cast<size_t>(start_s * config.imu.rate_hz);
    const Integrated r = integrate(seq, k0, k0 + per_s);
    const auto& gt = seq.ground_truth[k0 + per_s];
    EXPECT_LT((r.p - gt.T_W_B.translation()).norm(), 1e-5) << start_s;
    EXPECT_LT((r.v - gt.v_W).norm(), 1e-5) << start_s;
    // The midpoint rotation rule at 200 Hz leaves ~3e-7 rad after 1 s; the data are exact.
    EXPECT_LT(se3::logSO3(r.R.transpose() * gt.T_W_B.rotation()).norm(), 1e-6) << start_s;
  }
}

TEST_F(TrajectoryImuTest, NoisyImuStaysWithinItsNoiseModel) {
  std::mt19937 rng(11);
  const ImuSimulator sim(config.imu, config.initial_gyro_bias_sigma, config.initial_accel_bias_sigma);
  const ImuSequence seq = sim.simulate(traj, 59.0, rng);
  const double T = 1.0;
  // White accelerometer noise double-integrated, plus gravity misprojected by the attitude
  // random walk of the gyro noise.
  const double sa = config.imu.accelerometer_noise_density, sg = config.imu.gyroscope_noise_density;
  const double sigma_p = std::sqrt(sa * sa * T * T * T / 3 + std::pow(imu::kGravity_m_s2 * sg, 2) * std::pow(T, 5) / 20);
  const size_t per_s = static_cast<size_t>(config.imu.rate_hz);
  int within = 0, n = 0;
  double sum_sq = 0;
  for (size_t w = 0; w < 55; ++w) {
    const size_t k0 = (w + 2) * per_s;
    const Integrated r = integrate(seq, k0, k0 + per_s);
    const Eigen::Vector3d e = r.p - seq.ground_truth[k0 + per_s].T_W_B.translation();
    for (int i = 0; i < 3; ++i) {
      ++n;
      within += std::abs(e[i]) < 3 * sigma_p;
      sum_sq += e[i] * e[i];
    }
  }
  const double rms = std::sqrt(sum_sq / n);
  EXPECT_GE(within, static_cast<int>(0.97 * n));
  EXPECT_GT(rms, 0.6 * sigma_p);  // the noise is really there
  EXPECT_LT(rms, 1.4 * sigma_p);
}

TEST_F(TrajectoryImuTest, BiasRandomWalkHasTheModelledStep) {
  std::mt19937 rng(5);
  const ImuSimulator sim(config.imu, 0.0, 0.0);
  const ImuSequence seq = sim.simulate(traj, 40.0, rng);
  const double dt = 1.0 / config.imu.rate_hz;
  double sg = 0, sa = 0;
  size_t n = 0;
  for (size_t k = 1; k < seq.ground_truth.size(); ++k, n += 3) {
    sg += (seq.ground_truth[k].gyro_bias_rad_s - seq.ground_truth[k - 1].gyro_bias_rad_s).squaredNorm();
    sa += (seq.ground_truth[k].accel_bias_m_s2 - seq.ground_truth[k - 1].accel_bias_m_s2).squaredNorm();
  }
  EXPECT_NEAR(std::sqrt(sg / n), config.imu.gyroscope_random_walk * std::sqrt(dt),
              0.05 * config.imu.gyroscope_random_walk * std::sqrt(dt));
  EXPECT_NEAR(std::sqrt(sa / n), config.imu.accelerometer_random_walk * std::sqrt(dt),
              0.05 * config.imu.accelerometer_random_walk * std::sqrt(dt));
  // Stamps start at 1 s and are exactly periodic.
  EXPECT_EQ(seq.samples.front().t_ns, kStartTimeNs);
  EXPECT_EQ(seq.samples[1].t_ns - seq.samples[0].t_ns, 5000000);
}

}  // namespace
}  // namespace seavio::simulate
