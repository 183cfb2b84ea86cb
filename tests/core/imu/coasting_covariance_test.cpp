// The coasting covariance: one correlated error state from the last visual fix,
// propagated frame by frame, must grow like the dead-reckoning error it describes.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "core/imu/coasting_covariance.hpp"
#include "core/imu/imu_integrator.hpp"

namespace seavio::imu {
namespace coasting_covariance_test {
namespace {

constexpr double kRate = 200.0;

/// Exact samples of a vehicle at rest, level: no rotation, specific force +g along z.
std::vector<ImuSample> atRest(double seconds) {
  std::vector<ImuSample> s;
  for (int i = 0; i <= static_cast<int>(seconds * kRate); ++i)
    s.push_back({static_cast<int64_t>(std::llround(i * 1e9 / kRate)), Eigen::Vector3d::Zero(),
                 Eigen::Vector3d(0, 0, kGravity_m_s2)});
  return s;
}

/// Propagated over `seconds` in 10 Hz frames (as the odometry calls it) from `start`.
CoastingCovariance coast(const CoastingStart& start, double seconds, const ImuNoise& noise) {
  const std::vector<ImuSample> samples = atRest(seconds);
  CoastingCovariance c;
  c.start(start);
  const int frames = static_cast<int>(seconds * 10);
  for (int k = 0; k < frames; ++k)
    c.propagate(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), samples,
                k * 100'000'000LL, (k + 1) * 100'000'000LL, noise);
  return c;
}

ImuNoise noiseless() {
  ImuNoise n;
  n.gyroscope_noise_density = n.accelerometer_noise_density = 0;
  n.gyroscope_random_walk = n.accelerometer_random_walk = 0;
  return n;
}

double positionSigma(const CoastingCovariance& c, int axis) { return std::sqrt(c.covariance()(6 + axis, 6 + axis)); }

TEST(CoastingCovariance, EachErrorSourceGrowsThePositionAsDeadReckoningDoesAcrossFrames) {
  const double t = 5.0;
  // GIVEN only a velocity error of 5 cm/s THEN after 5 s (50 frames) the position error is
  // 25 cm: the frames stay correlated (independent per-frame sums would give 3.5 cm)
  {
    CoastingStart s{0, 0.05, 0, 0};
    const CoastingCovariance c = coast(s, t, noiseless());
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(positionSigma(c, a), 0.05 * t, 1e-3);
  }
  // GIVEN only an accelerometer bias error THEN 0.5 b t^2 on every axis
  {
    CoastingStart s{0, 0, 0, 0.03};
    const CoastingCovariance c = coast(s, t, noiseless());
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(positionSigma(c, a), 0.5 * 0.03 * t * t, 2e-3);
  }
  // GIVEN only a tilt error THEN gravity leaks into the horizontal axes, 0.5 g theta t^2,
  // and not into the vertical one
  {
    CoastingStart s{0.005, 0, 0, 0};
    const CoastingCovariance c = coast(s, t, noiseless());
    EXPECT_NEAR(positionSigma(c, 0), 0.5 * kGravity_m_s2 * 0.005 * t * t, 0.01);
    EXPECT_NEAR(positionSigma(c, 1), 0.5 * kGravity_m_s2 * 0.005 * t * t, 0.01);
    EXPECT_LT(positionSigma(c, 2), 1e-3);
  }
  // GIVEN only a gyro bias error THEN the tilt grows linearly, the position with t^3: g b t^3 / 6
  {
    CoastingStart s{0, 0, 3e-4, 0};
    const CoastingCovariance c = coast(s, t, noiseless());
    EXPECT_NEAR(positionSigma(c, 0), kGravity_m_s2 * 3e-4 * t * t * t / 6, 0.005);
    EXPECT_NEAR(std::sqrt(c.covariance()(0, 0)), 3e-4 * t, 1e-5);
  }
}

TEST(CoastingCovariance, MatchesTheSpreadOfMonteCarloDeadReckoning) {
  // GIVEN 400 dead-reckoning runs over 2 s at rest, each from a start drawn from the
  // handed-over uncertainties (tilt, velocity, gyro and accelerometer bias) with the IMU's
  // white noise on every sample
  const CoastingStart start{0.004, 0.03, 5e-4, 0.04};
  const ImuNoise noise{};
  const double seconds = 2.0;
  std::mt19937 rng(20261201);
  std::normal_distribution<double> n01;
  auto draw = [&](double sigma) -> Eigen::Vector3d { return Eigen::Vector3d(n01(rng), n01(rng), n01(rng)) * sigma; };
  const int runs = 400;
  std::vector<Eigen::Vector3d> errors;
  for (int r = 0; r < runs; ++r) {
    const Eigen::Vector3d bg = draw(start.gyro_bias_sigma_rad_s), ba = draw(start.accel_bias_sigma_m_s2);
    std::vector<ImuSample> samples = atRest(seconds);
    for (ImuSample& s : samples) {
      s.gyro_rad_s += bg + draw(noise.gyroscope_noise_density * std::sqrt(kRate));
      s.accel_m_s2 += ba + draw(noise.accelerometer_noise_density * std::sqrt(kRate));
    }
    NavState est;
    est.T_W_B.linear() = se3::expSO3(draw(start.attitude_sigma_rad));
    est.v_W = draw(start.velocity_sigma_m_s);
    errors.push_back(propagate(est, Matrix9d::Zero(), samples, samples.back().t_ns, noise).state.T_W_B.translation());
  }
  Eigen::Matrix3d empirical = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& e : errors) empirical += e * e.transpose();
  empirical /= runs;
  // WHEN the covariance is propagated over the same 2 s in 10 Hz frames
  const CoastingCovariance c = coast(start, seconds, noise);
  const Eigen::Matrix3d predicted = c.covariance().block<3, 3>(6, 6);
  // THEN every axis' predicted variance matches the runs' (400 runs: +-15% sampling error at
  // 2 sigma), and the normalised error squared averages the state's dimension (NEES ~ 3)
  double nees = 0;
  const Eigen::Matrix3d inv = predicted.inverse();
  for (const Eigen::Vector3d& e : errors) nees += e.dot(inv * e);
  nees /= runs;
  for (int a = 0; a < 3; ++a) {
    SCOPED_TRACE(a);
    EXPECT_GT(predicted(a, a), 0.8 * empirical(a, a));
    EXPECT_LT(predicted(a, a), 1.25 * empirical(a, a));
  }
  EXPECT_GT(nees, 2.6);
  EXPECT_LT(nees, 3.4);
  std::printf("2 s at rest: predicted sigma %.4f %.4f %.4f m, Monte Carlo %.4f %.4f %.4f m, NEES %.2f\n",
              std::sqrt(predicted(0, 0)), std::sqrt(predicted(1, 1)), std::sqrt(predicted(2, 2)),
              std::sqrt(empirical(0, 0)), std::sqrt(empirical(1, 1)), std::sqrt(empirical(2, 2)), nees);
}

TEST(CoastingCovariance, PoseCovarianceIsInTheWorldFrameAndStopEndsTheOutage) {
  CoastingCovariance c = coast({0.01, 0.05, 0, 0}, 1.0, ImuNoise{});
  EXPECT_TRUE(c.active());
  // A body yawed by 90 deg: the attitude block turns with it, the position block stays in W.
  const Eigen::Matrix3d R = se3::expSO3(Eigen::Vector3d(0, 0, M_PI / 2));
  const Eigen::Matrix<double, 6, 6> P = c.poseCovariance(R);
  EXPECT_TRUE(P.isApprox(P.transpose()));
  const Eigen::Matrix3d attitude_W = R * c.covariance().topLeftCorner<3, 3>() * R.transpose();
  const Eigen::Matrix3d position_W = c.covariance().block<3, 3>(6, 6);
  EXPECT_TRUE((P.topLeftCorner<3, 3>().isApprox(attitude_W)));
  EXPECT_TRUE((P.bottomRightCorner<3, 3>().isApprox(position_W)));
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(P);
  EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-12);
  c.stop();
  EXPECT_FALSE(c.active());
}

}  // namespace
}  // namespace coasting_covariance_test
}  // namespace seavio::imu
