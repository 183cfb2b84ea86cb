#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "core/imu/error_state_filter.hpp"
#include "core/imu/imu_integrator.hpp"

namespace seavio::imu {
namespace error_state_filter_test {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

/// A survey-like motion: surge oscillating +-0.8 m/s^2 (accelerating at t = 0), a slow turn,
/// heave, and wave roll/pitch of a few degrees at 5-7 s periods.
struct Motion {
  Vector3d p(double t) const {
    return {0.5 * t - 0.4 * std::cos(std::sqrt(2.0) * t), 2.0 * std::sin(0.05 * t), 0.1 * std::sin(0.8 * t)};
  }
  Vector3d v(double t) const {
    return {0.5 + 0.4 * std::sqrt(2.0) * std::sin(std::sqrt(2.0) * t), 0.1 * std::cos(0.05 * t),
            0.08 * std::cos(0.8 * t)};
  }
  Vector3d a(double t) const {
    return {0.8 * std::cos(std::sqrt(2.0) * t), -0.005 * std::sin(0.05 * t), -0.064 * std::sin(0.8 * t)};
  }
  Matrix3d R(double t) const {
    return (Eigen::AngleAxisd(0.05 * t, Vector3d::UnitZ()) *
            Eigen::AngleAxisd(0.05 * std::sin(0.9 * t + 1.0), Vector3d::UnitY()) *
            Eigen::AngleAxisd(0.06 * std::sin(1.2 * t), Vector3d::UnitX()))
        .toRotationMatrix();
  }
  Vector3d w_B(double t) const {
    const double h = 1e-5;
    return se3::logSO3(R(t - h).transpose() * R(t + h)) / (2 * h);
  }
  NavState state(double t) const {
    NavState s;
    s.t_ns = ns(t);
    s.T_W_B.linear() = R(t);
    s.T_W_B.translation() = p(t);
    s.v_W = v(t);
    return s;
  }
  static int64_t ns(double t) { return static_cast<int64_t>(std::llround(t * 1e9)); }
};

/// The IMU on `Motion` with white noise, a random-walk bias and optional faults.
struct ImuSim {
  Motion motion;
  ImuNoise noise;
  Vector3d bg{2e-3, -1.5e-3, 1e-3}, ba{0.03, -0.02, 0.04};
  std::mt19937 rng{7};
  bool noisy = true;
  ImuSample sample(double t) {
    std::normal_distribution<double> n(0.0, 1.0);
    const auto draw = [&](double s) { return noisy ? Vector3d(s * n(rng), s * n(rng), s * n(rng)) : Vector3d::Zero(); };
    const double dt = 1.0 / noise.rate_hz;
    bg += draw(noise.gyroscope_random_walk * std::sqrt(dt));
    ba += draw(noise.accelerometer_random_walk * std::sqrt(dt));
    ImuSample s;
    s.t_ns = Motion::ns(t);
    s.gyro_rad_s = motion.w_B(t) + bg + draw(noise.gyroscope_noise_density * std::sqrt(noise.rate_hz));
    s.accel_m_s2 = motion.R(t).transpose() * (motion.a(t) - gravityW()) + ba +
                   draw(noise.accelerometer_noise_density * std::sqrt(noise.rate_hz));
    return s;
  }
};

/// Vision's relative motion between body poses at t0 and t1, with noise drawn from `C`.
RelativeMotion visualMotion(const Motion& m, double t0, double t1, const Matrix6d& C, std::mt19937& rng) {
  RelativeMotion z;
  z.covariance = C;
  Eigen::Matrix<double, 6, 1> e;
  std::normal_distribution<double> n(0.0, 1.0);
  for (int i = 0; i < 6; ++i) e[i] = n(rng);
  const Eigen::Matrix<double, 6, 1> noise = Eigen::LLT<Matrix6d>(C).matrixL() * e;
  z.R_prev_curr = m.R(t0).transpose() * m.R(t1) * se3::expSO3(noise.head<3>());
  z.p_prev_curr = m.R(t0).transpose() * (m.p(t1) - m.p(t0)) + noise.tail<3>();
  return z;
}

Matrix6d visionCovariance() {
  Matrix6d C = Matrix6d::Zero();
  C.diagonal() << 1e-6, 1e-6, 1e-6, 2.5e-5, 2.5e-5, 2.5e-5;  // 1 mrad, 5 mm per frame
  return C;
}

double tiltError(const Matrix3d& R_est, const Matrix3d& R_true) {
  const Vector3d z_est = R_est.transpose() * Vector3d::UnitZ(), z_true = R_true.transpose() * Vector3d::UnitZ();
  return std::acos(std::clamp(z_est.dot(z_true), -1.0, 1.0));
}

/// Runs the filter over [t0, t1] at `frame_hz`, vision every frame; `imu_fault(t, sample)` may
/// corrupt samples and `vision_fault(t, z)` measurements. Returns the outcomes' counts.
struct Scenario {
  ImuSim imu;
  ErrorStateFilter filter;
  std::mt19937 rng{11};
  double frame_hz = 10.0;
  std::vector<double> nees;
  int accepted = 0;
  template <class ImuFault, class VisionFault>
  void go(double t0, double t1, ImuFault imu_fault, VisionFault vision_fault) {
    const int per_frame = static_cast<int>(imu.noise.rate_hz / frame_hz);
    const double dt = 1.0 / imu.noise.rate_hz;
    std::vector<ImuSample> samples;
    double t_prev = t0;
    for (int k = 1; t0 + k * per_frame * dt <= t1 + 1e-9; ++k) {
      const double t = t0 + k * per_frame * dt;
      samples.clear();
      for (int i = (k - 1) * per_frame + 1; i <= k * per_frame; ++i) {
        ImuSample s = imu.sample(t0 + i * dt);
        imu_fault(t0 + i * dt, s);
        samples.push_back(s);
      }
      filter.propagate(samples, Motion::ns(t));
      const RelativeMotion pred = filter.predictedMotion();
      Eigen::Matrix<double, 6, 1> e;
      e.head<3>() = se3::logSO3(pred.R_prev_curr.transpose() * imu.motion.R(t_prev).transpose() * imu.motion.R(t));
      e.tail<3>() = imu.motion.R(t_prev).transpose() * (imu.motion.p(t) - imu.motion.p(t_prev)) - pred.p_prev_curr;
      nees.push_back(e.dot(pred.covariance.ldlt().solve(e)));
      RelativeMotion z = visualMotion(imu.motion, t_prev, t, visionCovariance(), rng);
      vision_fault(t, z);
      if (filter.update(z) != UpdateOutcome::kRefused) ++accepted;
      filter.clonePose();
      t_prev = t;
    }
  }
  void go(double t0, double t1) {
    go(t0, t1, [](double, ImuSample&) {}, [](double, RelativeMotion&) {});
  }
  /// Starts from the truth at t0 (biases unknown: zero, at the datasheet spread).
  void startAtTruth(double t0) {
    NavState s = imu.motion.state(t0);
    filter.startFrom(s);
  }
};

TEST(ErrorStateFilter, NoiselessPropagationMatchesTheIntegrator) {
  // GIVEN 2 s of exact IMU data on the survey motion, and the filter at the true start
  ImuSim sim;
  sim.noisy = false;
  sim.bg.setZero();
  sim.ba.setZero();
  std::vector<ImuSample> samples;
  for (int i = 0; i <= 400; ++i) samples.push_back(sim.sample(i / 200.0));
  ErrorStateFilter f;
  f.startFrom(sim.motion.state(0));
  // WHEN propagated to 2 s (in two calls, the first ending between samples)
  f.propagate(samples, Motion::ns(0.7777));
  const int used = f.propagate(samples, Motion::ns(2.0));
  // THEN it lands on the truth and on the dead reckoning of imu_integrator
  const NavState truth = sim.motion.state(2.0);
  const NavState s = f.state();
  const ImuPropagation dr = propagate(sim.motion.state(0), Matrix9d::Zero(), samples, Motion::ns(2.0), ImuNoise{});
  EXPECT_LT((s.T_W_B.translation() - truth.T_W_B.translation()).norm(), 1e-3);
  EXPECT_LT((s.v_W - truth.v_W).norm(), 1e-3);
  EXPECT_LT(se3::logSO3(s.T_W_B.rotation().transpose() * truth.T_W_B.rotation()).norm(), 1e-5);
  // (the interval split at 0.7777 s is integrated as two midpoint steps, not one)
  EXPECT_LT((s.T_W_B.translation() - dr.state.T_W_B.translation()).norm(), 1e-4);
  EXPECT_EQ(used, 400 - 155);
  EXPECT_EQ(f.spikes(), 0u);
  // AND its covariance grew (velocity unknown at start: position variance ~ (1 m/s * 2 s)^2)
  EXPECT_GT(f.covariance()(kEsPos, kEsPos), 3.0);
}

TEST(ErrorStateFilter, MovingStartLevelsOnTheFirstVisualMotions) {
  // GIVEN a start-up window of the vehicle surging at +0.8 m/s^2 (levelling on it is ~80 mrad off)
  Scenario run;
  std::vector<ImuSample> lead;
  for (int i = -200; i <= 0; ++i) lead.push_back(run.imu.sample(i / 200.0));
  const StartKind kind = run.filter.start(0, lead);
  EXPECT_NE(kind, StartKind::kRest);
  const double tilt0 = tiltError(run.filter.state().T_W_B.rotation(), run.imu.motion.R(0));
  EXPECT_GT(tilt0, 0.03);
  // WHEN 20 s of vision at 10 Hz and the IMU are fused
  run.go(0.0, 20.0);
  // THEN the tilt is found within the filter's 3 sigma and a few mrad
  const double tilt = tiltError(run.filter.state().T_W_B.rotation(), run.imu.motion.R(20.0));
  const double sigma = std::sqrt(run.filter.covariance()(0, 0) + run.filter.covariance()(1, 1));
  EXPECT_LT(tilt, 0.01) << "start-up tilt error " << tilt0;
  EXPECT_LT(tilt, 3 * sigma + 1e-4);
  EXPECT_LT((run.filter.state().v_W - run.imu.motion.v(20.0)).norm(), 0.05);
  EXPECT_EQ(run.accepted, 200);
}

TEST(ErrorStateFilter, RestStartTakesTheGyroBias) {
  // GIVEN a second of a still IMU (the true gyro bias is its mean rate)
  ImuSim sim;
  std::vector<ImuSample> still;
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  const double sg = sim.noise.gyroscope_noise_density * std::sqrt(sim.noise.rate_hz);
  for (int i = 0; i <= 200; ++i)
    still.push_back(ImuSample{Motion::ns(i / 200.0), sim.bg + sg * Vector3d(n(rng), n(rng), n(rng)),
                              Vector3d(0, 0, kGravity_m_s2)});
  ErrorStateFilter f;
  // WHEN started on it
  EXPECT_EQ(f.start(Motion::ns(1.0), still), StartKind::kRest);
  // THEN the gyro bias is the mean rate, within the filter's 3 sigma
  const double sigma = std::sqrt(f.covariance()(kEsBg, kEsBg));
  EXPECT_LT((f.gyroBias() - sim.bg).cwiseAbs().maxCoeff(), 3 * sigma);
  EXPECT_LT(sigma, 1e-3);
}

TEST(ErrorStateFilter, BiasStepIsTrackedWithinThreeSigma) {
  // GIVEN 30 s of motion, then a step of the gyro (z) and accelerometer (x) biases
  Scenario run;
  run.startAtTruth(0.0);
  run.go(0.0, 30.0);
  run.imu.bg.z() += 2e-3;
  run.imu.ba.x() += 0.05;
  // WHEN 40 s more are fused
  run.go(30.0, 70.0);
  // THEN both biases lie within the filter's 3 sigma of the truth, on every axis
  const EsMatrix& P = run.filter.covariance();
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::abs(run.filter.gyroBias()[i] - run.imu.bg[i]), 3 * std::sqrt(P(kEsBg + i, kEsBg + i))) << i;
    EXPECT_LT(std::abs(run.filter.accelBias()[i] - run.imu.ba[i]), 3 * std::sqrt(P(kEsBa + i, kEsBa + i))) << i;
  }
  // AND most of each step is in the estimate (the accelerometer's own walk over 40 s is ~0.02)
  EXPECT_LT(std::abs(run.filter.gyroBias().z() - run.imu.bg.z()), 1e-3);
  EXPECT_LT(std::abs(run.filter.accelBias().x() - run.imu.ba.x()), 0.035);
}

TEST(ErrorStateFilter, SpikeIsDetectedAndNotIntegrated) {
  // GIVEN the same 5 s fused twice, the second with one gyro and one accel sample far out of range
  Scenario clean, spiked;
  clean.startAtTruth(0.0);
  spiked.startAtTruth(0.0);
  clean.go(0.0, 5.0);
  spiked.go(0.0, 5.0, [](double t, ImuSample& s) {
    if (std::abs(t - 2.5) < 1e-6) s.gyro_rad_s.x() = 500.0;
    if (std::abs(t - 3.0) < 1e-6) s.accel_m_s2.z() = std::numeric_limits<double>::quiet_NaN();
  }, [](double, RelativeMotion&) {});
  // THEN both are counted, the state stays finite and within noise of the clean run
  EXPECT_EQ(spiked.filter.spikes(), 2u);
  EXPECT_EQ(clean.filter.spikes(), 0u);
  EXPECT_EQ(spiked.filter.refused(), 0u);
  EXPECT_LT((spiked.filter.state().T_W_B.translation() - clean.filter.state().T_W_B.translation()).norm(), 5e-3);
  EXPECT_LT(se3::logSO3(spiked.filter.state().T_W_B.rotation().transpose() * clean.filter.state().T_W_B.rotation())
                .norm(),
            1e-3);
}

TEST(ErrorStateFilter, VisionOutlierIsRefusedByTheGate) {
  // GIVEN a converged filter
  Scenario run;
  run.startAtTruth(0.0);
  run.go(0.0, 10.0);
  // WHEN one visual motion is 20 cm off and the rest are fine
  run.go(10.0, 15.0, [](double, ImuSample&) {}, [](double t, RelativeMotion& z) {
    if (std::abs(t - 12.0) < 1e-6) z.p_prev_curr.x() += 0.2;
  });
  // THEN exactly that one is refused, the IMU is not blamed, and the pose holds
  EXPECT_EQ(run.filter.refused(), 1u);
  EXPECT_EQ(run.filter.imuFaults(), 0u);
  EXPECT_EQ(run.filter.refusedInARow(), 0);
  EXPECT_LT((run.filter.state().v_W - run.imu.motion.v(15.0)).norm(), 0.02);
}

TEST(ErrorStateFilter, LongDisagreementBlamesTheFaultyImu) {
  // GIVEN a converged filter whose gyro then reads 0.05 rad/s off on z (a glitching sensor)
  Scenario run;
  run.startAtTruth(0.0);
  run.go(0.0, 10.0);
  const auto glitch = [](double, ImuSample& s) { s.gyro_rad_s.z() += 0.05; };
  const auto clean = [](double, RelativeMotion&) {};
  run.go(10.0, 15.0, glitch, clean);
  const Matrix3d R15 = run.filter.state().T_W_B.rotation();
  run.go(15.0, 20.0, glitch, clean);
  // THEN vision was refused a few frames, then the IMU judged at fault once, and the filter
  // follows vision: the offset sits in the bias, the turn since is vision's, the tilt holds
  // (the heading the refused frames lost stays lost: relative motions cannot return it)
  EXPECT_GE(run.filter.refused(), 1u);
  EXPECT_EQ(run.filter.imuFaults(), 1u);
  EXPECT_EQ(run.filter.refusedInARow(), 0);
  EXPECT_LT(std::abs(run.filter.gyroBias().z() - run.imu.bg.z() - 0.05), 5e-3);
  EXPECT_LT((run.filter.state().v_W - run.imu.motion.v(20.0)).norm(), 0.1);
  const Matrix3d turn = R15.transpose() * run.filter.state().T_W_B.rotation();
  const Matrix3d true_turn = run.imu.motion.R(15.0).transpose() * run.imu.motion.R(20.0);
  EXPECT_LT(se3::logSO3(turn.transpose() * true_turn).norm(), 0.015);  // the IMU alone: 0.25 rad
  EXPECT_LT(tiltError(run.filter.state().T_W_B.rotation(), run.imu.motion.R(20.0)), 0.01);
}

TEST(ErrorStateFilter, ShortVisionGlitchDoesNotBlameTheImu) {
  // GIVEN a converged filter and vision wrong for fewer frames than the fault rule needs
  Scenario run;
  run.startAtTruth(0.0);
  run.go(0.0, 10.0);
  run.go(10.0, 15.0, [](double, ImuSample&) {}, [](double t, RelativeMotion& z) {
    if (t > 12.0 && t < 12.35) z.p_prev_curr.y() += 0.15;
  });
  // THEN those frames are refused and nothing else: the IMU stays trusted
  EXPECT_EQ(run.filter.refused(), 3u);
  EXPECT_EQ(run.filter.imuFaults(), 0u);
  EXPECT_LT((run.filter.state().v_W - run.imu.motion.v(15.0)).norm(), 0.02);
}

TEST(ErrorStateFilter, PoseIncrementNeesStaysInTheChiSquareBand) {
  // GIVEN 60 s of simulated survey from a moving start, biases unknown
  Scenario run;
  std::vector<ImuSample> lead;
  for (int i = -200; i <= 0; ++i) lead.push_back(run.imu.sample(i / 200.0));
  run.filter.start(0, lead);
  run.go(0.0, 60.0);
  // THEN after the first 5 s, the predicted pose increment's NEES lies in the 95 % band of a
  // 6-dof chi-square on at least 90 % of the frames, and its mean near 6
  int in_band = 0, n = 0;
  double sum = 0;
  for (std::size_t k = 50; k < run.nees.size(); ++k, ++n) {
    in_band += run.nees[k] >= 1.237 && run.nees[k] <= 14.449;
    sum += run.nees[k];
  }
  EXPECT_GE(in_band, 0.9 * n) << "mean NEES " << sum / n;
  EXPECT_GT(sum / n, 4.0);
  EXPECT_LT(sum / n, 8.0);
}

TEST(ErrorStateFilter, CameraAndBodyCovariancesInvert) {
  Matrix6d C = Matrix6d::Identity() * 1e-4;
  C(0, 4) = C(4, 0) = 5e-5;
  Eigen::Isometry3d T_B_C = Eigen::Isometry3d::Identity();
  T_B_C.linear() = se3::expSO3(Vector3d(0.1, -0.2, 1.5));
  T_B_C.translation() = Vector3d(0.2, 0.05, -0.1);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = se3::expSO3(Vector3d(0.01, 0.02, 0.1));
  T.translation() = Vector3d(0.3, -0.1, 0.05);
  const Matrix6d B = cameraToBodyMotionCovariance(C, T, T_B_C);
  EXPECT_LT((bodyToCameraMotionCovariance(B, T, T_B_C) - C).norm(), 1e-12);
  EXPECT_GT((B - C).norm(), 1e-6);
}

}  // namespace
}  // namespace error_state_filter_test
}  // namespace seavio::imu
