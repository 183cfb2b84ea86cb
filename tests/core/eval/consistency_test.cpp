#include "core/eval/consistency.hpp"

#include <random>

#include <gtest/gtest.h>

#include "core/common/se3.hpp"

using namespace seavio;
using namespace seavio::eval;

namespace {

/// A body turning and climbing at 10 Hz for `seconds`, with constant true biases.
std::vector<TruthSample> turningTruth(double seconds, const Eigen::Vector3d& bg, const Eigen::Vector3d& ba) {
  std::vector<TruthSample> out;
  for (int k = 0; k <= static_cast<int>(seconds * 10); ++k) {
    TruthSample s;
    s.t_ns = 1'000'000'000 + int64_t(k) * 100'000'000;
    const double t = 0.1 * k;
    s.T_W_B.linear() = se3::expSO3(Eigen::Vector3d(0.02 * t, 0.3 * std::sin(t), 0.1 * t));
    s.T_W_B.translation() = Eigen::Vector3d(std::cos(0.1 * t) * 5, std::sin(0.1 * t) * 5, 0.05 * t);
    s.gyro_bias_rad_s = bg;
    s.accel_bias_m_s2 = ba;
    out.push_back(s);
  }
  return out;
}

/// A covariance with correlations and rotation and translation of different sizes.
Matrix6d claimedCovariance() {
  Matrix6d A = Matrix6d::Identity();
  A.diagonal() << 1e-3, 2e-3, 5e-4, 4e-3, 1e-2, 2e-3;
  A(3, 1) = 1.5e-3;  // the pitch/surge coupling of a flat floor
  A(4, 0) = -2e-3;
  A(5, 3) = 1e-3;
  return A * A.transpose();
}

/// Frames whose increments err by draws from `draw_cov` and claim `claimed_cov`, chained in a
/// world of their own (an increment needs no alignment).
std::vector<ConsistencyFrame> perturbedFrames(const std::vector<TruthSample>& truth, const Matrix6d& draw_cov,
                                              const Matrix6d& claimed_cov, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01;
  const Matrix6d L = draw_cov.llt().matrixL();
  std::vector<ConsistencyFrame> out;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = se3::expSO3(Eigen::Vector3d(0.1, -0.2, 1.0));
  T.translation() = Eigen::Vector3d(3, -4, 1);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    ConsistencyFrame f;
    f.t_ns = truth[i].t_ns;
    if (i > 0) {
      const Eigen::Isometry3d inc = truth[i - 1].T_W_B.inverse() * truth[i].T_W_B;
      Eigen::Matrix<double, 6, 1> z;
      for (int k = 0; k < 6; ++k) z(k) = n01(rng);
      const Eigen::Matrix<double, 6, 1> e = L * z;
      Eigen::Isometry3d est = Eigen::Isometry3d::Identity();
      est.linear() = inc.rotation() * se3::expSO3(e.head<3>());
      est.translation() = inc.translation() + e.tail<3>();
      T = T * est;
      f.increment_covariance = claimed_cov;
    }
    f.T_W_B = T;
    out.push_back(f);
  }
  return out;
}

}  // namespace

TEST(Consistency, ErrorsDrawnFromTheClaimedCovarianceFillTheChiSquareBand) {
  const auto truth = turningTruth(300, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  const Matrix6d C = claimedCovariance();
  const ConsistencyFigures f = evaluateConsistency(truth, perturbedFrames(truth, C, C, 7));
  EXPECT_EQ(f.nees_frames, static_cast<int>(truth.size()) - 1);
  EXPECT_NEAR(f.nees_in_band_fraction, 0.95, 0.02);
  EXPECT_NEAR(f.nees_median, 5.35, 0.4);        // chi-square, 6 dof
  EXPECT_NEAR(f.nees_rotation_median, 2.37, 0.3);  // 3 dof
  EXPECT_NEAR(f.nees_translation_median, 2.37, 0.3);
  EXPECT_FALSE(f.bias_known);  // the truth's biases are all zero: unknown
}

TEST(Consistency, TenTimesUnderClaimedCovarianceLeavesTheBand) {
  const auto truth = turningTruth(300, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  const Matrix6d C = claimedCovariance();
  const ConsistencyFigures f = evaluateConsistency(truth, perturbedFrames(truth, C, C / 10, 7));
  // NEES 10x chi-square(6): inside 14.449 only when chi-square < 1.44, about 4 % of draws.
  EXPECT_LT(f.nees_in_band_fraction, 0.10);
  EXPECT_NEAR(f.nees_median, 53.5, 5.0);
}

TEST(Consistency, RotationErrorIsARightPerturbationInTheCurrentBody) {
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = se3::expSO3(Eigen::Vector3d(M_PI / 2, 0, 0));
  truth.translation() = Eigen::Vector3d(1, 0, 0);
  Eigen::Isometry3d est = truth;
  est.linear() = truth.rotation() * se3::expSO3(Eigen::Vector3d(0, 0, 0.01));
  est.translation() += Eigen::Vector3d(0, 0.02, 0);
  Matrix6d C = Matrix6d::Zero();
  C.diagonal() << 1e-10, 1e-10, 1e-4, 1e-10, 4e-4, 1e-10;  // only z turn and y shift allowed
  const IncrementNees n = incrementNees(est, truth, C);
  ASSERT_TRUE(n.ok);
  EXPECT_NEAR(n.rotation, 1.0, 1e-6);
  EXPECT_NEAR(n.translation, 1.0, 1e-6);
  EXPECT_NEAR(n.full, 2.0, 1e-6);
  EXPECT_FALSE(incrementNees(est, truth, Matrix6d::Zero()).ok);
}

TEST(Consistency, BiasFractionCountsFramesAfterTheSettlingTimeOnly) {
  const Eigen::Vector3d bg(1e-3, -2e-3, 5e-4), ba(0.02, -0.01, 0.03);
  const auto truth = turningTruth(39.9, bg, ba);
  const Eigen::Vector3d sg = Eigen::Vector3d::Constant(1e-4), sa = Eigen::Vector3d::Constant(5e-3);
  std::vector<ConsistencyFrame> frames;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    ConsistencyFrame f;
    f.t_ns = truth[i].t_ns;
    f.T_W_B = truth[i].T_W_B;
    f.gyro_bias_sigma_rad_s = sg;
    f.accel_bias_sigma_m_s2 = sa;
    const double t_s = 1e-9 * double(truth[i].t_ns - truth.front().t_ns);
    // Far off before 30 s (not judged); then 2.9 sigma off, except one accelerometer axis
    // 3.1 sigma off on every tenth frame.
    const double k_sigma = t_s < 30.0 ? 50.0 : 2.9;
    f.gyro_bias_rad_s = bg + k_sigma * sg;
    f.accel_bias_m_s2 = ba - k_sigma * sa;
    if (t_s >= 30.0 && i % 10 == 0) f.accel_bias_m_s2.y() = ba.y() + 3.1 * sa.y();
    frames.push_back(f);
  }
  const ConsistencyFigures f = evaluateConsistency(truth, frames);
  ASSERT_TRUE(f.bias_known);
  EXPECT_EQ(f.bias_frames, 100);  // 30.0 s to 39.9 s
  EXPECT_NEAR(f.bias_within_fraction, 0.9, 1e-12);
  EXPECT_EQ(f.nees_frames, 0);  // no increment claims a covariance

  // Too short to settle, or no sigma claimed (no IMU): nothing judged.
  ConsistencyParams p;
  p.bias_settle_s = 40.0;
  EXPECT_FALSE(evaluateConsistency(truth, frames, p).bias_known);
  for (auto& fr : frames) fr.gyro_bias_sigma_rad_s.setZero();
  EXPECT_FALSE(evaluateConsistency(truth, frames).bias_known);
}
