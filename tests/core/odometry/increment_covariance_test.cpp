// The increment between two frames tracked against one keyframe: its claimed covariance must
// fit its error (NEES) when both motions share the keyframe's pixel noise and the gyro prior
// since the keyframe, which the keyframe-to-frame covariance of the later frame alone does not.
#include <algorithm>
#include <random>
#include <vector>

#include <Eigen/Cholesky>

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "core/odometry/increment_covariance.hpp"
#include "core/odometry/motion_refinement.hpp"
#include "downward_rig.hpp"

namespace seavio::odometry {
namespace increment_covariance_test {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

constexpr double kModelSigma = 0.25;     // MotionRefinementParams' pixel model [px]
constexpr double kPriorSigma = 2e-5;     // the gyro since the keyframe [rad], shared
constexpr double kIntervalSigma = 5e-6;  // the gyro over the last interval [rad], the later frame's own

Eigen::Isometry3d step(double forward_m, double pitch_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.002, -forward_m, 0.001);
  return T;
}

Eigen::Vector2f noisy(const Eigen::Vector2d& uv, std::normal_distribution<double>& n, std::mt19937& rng) {
  return Eigen::Vector2f(static_cast<float>(uv.x() + n(rng)), static_cast<float>(uv.y() + n(rng)));
}

/// The left perturbation in the keyframe camera that takes `truth` to `est` (rotation,
/// translation; refineMotion's convention).
Vector6d leftError(const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth) {
  Vector6d d;
  const Eigen::Matrix3d dR = est.rotation() * truth.rotation().transpose();
  d.head<3>() = se3::logSO3(dR);
  d.tail<3>() = est.translation() - dR * truth.translation();
  return d;
}

double nees(const Vector6d& e, const Matrix6d& C) { return e.dot(Eigen::LLT<Matrix6d>(C).solve(e)); }

double mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return sum / static_cast<double>(v.size());
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Trials {
  std::vector<double> nees_claim, nees_keyframe_motion;
  double trace_ratio = 0;  ///< claimed increment translation / keyframe-to-frame, averaged
  double variance_factor_mean = 0;  ///< the later frame's ReferenceSensitivity::variance_factor, averaged
};

/// How a trial's pixels err.
struct PixelNoise {
  double sigma_px = kModelSigma;  ///< each pixel's own noise (the keyframe-left one's too unless aligned)
  /// > 0: as patch refinement makes them: the keyframe-left pixel (the template's origin) errs
  /// by this much and the other three follow it (a shift of the point along the floor); only
  /// they carry `sigma_px` (the alignment's).
  double template_follow_px = 0;
  bool claim_template_aligned = false;  ///< MotionRefinementParams::template_aligned
};

/// Frames 1 and 2 tracked against one keyframe over a floor 4 m below: each trial draws the
/// keyframe's pixels and the prior's error since the keyframe once for both, the frames' own
/// pixels and the last interval's gyro error apart.
Trials run(int trials, bool with_prior, const PixelNoise& noise) {
  const double pixel_noise_px = noise.sigma_px;
  const bool aligned = noise.template_follow_px > 0;
  const camera::RectifiedRig rig = test::rectifiedDownwardRig();
  const Eigen::Isometry3d T1 = step(0.10, 4e-4), T2 = step(0.20, 9e-4);  // keyframe <- frame
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> ux(-1.8, 1.8), uy(-1.0, 1.0), uz(-0.05, 0.05);
  std::normal_distribution<double> pix(0.0, pixel_noise_px), shared(0.0, kPriorSigma), own(0.0, kIntervalSigma);
  std::normal_distribution<double> follow(0.0, aligned ? noise.template_follow_px : 1.0);
  std::vector<Eigen::Vector3d> X;  // keyframe camera, seen from both frames
  const auto inside = [&](const Eigen::Vector2d& uv) {
    return uv.x() > 5 && uv.y() > 5 && uv.x() < rig.width - 5 && uv.y() < rig.height - 5;
  };
  while (X.size() < 120) {
    const Eigen::Vector3d p(ux(rng), uy(rng), 4.0 + uz(rng));
    bool ok = inside(rig.project(p, 0)) && inside(rig.project(p, 1));
    for (const Eigen::Isometry3d* T : {&T1, &T2})
      ok = ok && inside(rig.project(T->inverse() * p, 0)) && inside(rig.project(T->inverse() * p, 1));
    if (ok) X.push_back(p);
  }
  MotionRefinementParams params;
  params.pixel_sigma_px = kModelSigma;
  params.iterations = 12;
  params.min_rotation_sigma_rad = 1e-9;
  params.template_aligned = noise.claim_template_aligned;
  // Frame 1 matched every point, frame 2 all but the first 20, in another order.
  std::vector<uint32_t> ref1(X.size()), ref2;
  for (uint32_t i = 0; i < X.size(); ++i) ref1[i] = i;
  for (uint32_t i = static_cast<uint32_t>(X.size()); i-- > 20;) ref2.push_back(i);
  Trials out;
  for (int t = 0; t < trials; ++t) {
    std::vector<Eigen::Vector2f> kl(X.size()), kr(X.size());
    std::vector<Eigen::Vector2d> shift(X.size(), Eigen::Vector2d::Zero());  // what the aligned pixels follow
    for (std::size_t i = 0; i < X.size(); ++i) {
      if (aligned) {
        shift[i] = Eigen::Vector2d(follow(rng), follow(rng));
        kl[i] = (rig.project(X[i], 0) + shift[i]).cast<float>();
      } else {
        kl[i] = noisy(rig.project(X[i], 0), pix, rng);
      }
      kr[i] = noisy(rig.project(X[i], 1) + shift[i], pix, rng);
    }
    const Eigen::Vector3d e1(shared(rng), shared(rng), shared(rng));
    const Eigen::Vector3d e2 = e1 + Eigen::Vector3d(own(rng), own(rng), own(rng));
    const auto refine = [&](const Eigen::Isometry3d& T, const std::vector<uint32_t>& ref, const Eigen::Vector3d& e,
                            double prior_sigma, ReferenceSensitivity& s) {
      std::vector<geometry::QuadMatch> quads;
      for (uint32_t i : ref) {
        const Eigen::Vector3d Y = T.inverse() * X[i];
        quads.push_back({kl[i], kr[i], noisy(rig.project(Y, 0) + shift[i], pix, rng),
                         noisy(rig.project(Y, 1) + shift[i], pix, rng)});
      }
      std::vector<uint32_t> inliers(quads.size());
      for (uint32_t i = 0; i < inliers.size(); ++i) inliers[i] = i;
      RotationPrior prior;
      prior.valid = with_prior;
      prior.R_prev_curr = T.rotation() * se3::expSO3(e);
      prior.covariance = Eigen::Matrix3d::Identity() * prior_sigma * prior_sigma;
      MotionRefinementWorkspace ws;
      const MotionRefinementResult r = refineMotion(rig, quads, inliers, T, prior, params, ws, &s);
      EXPECT_TRUE(r.ok);
      return r;
    };
    ReferenceSensitivity s1, s2;
    const double sigma2 = std::sqrt(kPriorSigma * kPriorSigma + kIntervalSigma * kIntervalSigma);
    const MotionRefinementResult r1 = refine(T1, ref1, e1, kPriorSigma, s1);
    const MotionRefinementResult r2 = refine(T2, ref2, e2, sigma2, s2);
    KeyframeIncrementCovariance link;
    link.record(7, 100, s1, ref1, X.size());
    EXPECT_FALSE(link.increment(8, 100, s2, ref2)) << "another keyframe";
    EXPECT_FALSE(link.increment(7, 99, s2, ref2)) << "not the previous frame";
    const std::optional<Matrix6d> claim = link.increment(7, 100, s2, ref2);
    EXPECT_TRUE(claim.has_value());
    if (!claim) return out;
    const Vector6d e = leftError(r2.T_prev_curr, T2) - leftError(r1.T_prev_curr, T1);
    out.nees_claim.push_back(nees(e, *claim));
    out.variance_factor_mean += s2.variance_factor / trials;
    out.nees_keyframe_motion.push_back(nees(e, r2.covariance));
    out.trace_ratio += claim->bottomRightCorner<3, 3>().trace() / r2.covariance.bottomRightCorner<3, 3>().trace() / trials;
  }
  return out;
}

TEST(KeyframeIncrementCovariance, WithoutAPriorTheClaimFitsItsError) {
  // GIVEN 300 trials of two frames tracked against one keyframe, vision alone, the pixels as
  // noisy as the model says
  const Trials t = run(300, false, PixelNoise{});
  ASSERT_EQ(t.nees_claim.size(), 300u);
  // THEN the claim's NEES median is that of a chi-square with 6 dof (5.35)
  EXPECT_GT(median(t.nees_claim), 4.3);
  EXPECT_LT(median(t.nees_claim), 6.5);
}

TEST(KeyframeIncrementCovariance, TheSharedGyroPriorCancelsInTheClaim) {
  // GIVEN the same with the gyro since the keyframe as each motion's rotation prior, the later
  // prior extending the earlier one by an interval's independent error
  const Trials t = run(300, true, PixelNoise{});
  ASSERT_EQ(t.nees_claim.size(), 300u);
  // THEN the claim fits, where the later frame's keyframe-to-frame covariance would be several
  // times too loose: the prior's share cancels in the increment
  EXPECT_GT(median(t.nees_claim), 4.3);
  EXPECT_LT(median(t.nees_claim), 6.5);
  EXPECT_LT(median(t.nees_keyframe_motion), 2.5);
}

TEST(KeyframeIncrementCovariance, TheClaimTakesThePixelNoiseTheResidualsShow) {
  // GIVEN pixels half as noisy as the refinement's model
  const Trials t = run(300, true, PixelNoise{0.5 * kModelSigma});
  ASSERT_EQ(t.nees_claim.size(), 300u);
  // THEN the claim still fits (its pixel variance from the residuals), the model's would not
  EXPECT_GT(median(t.nees_claim), 4.3);
  EXPECT_LT(median(t.nees_claim), 6.5);
  EXPECT_LT(median(t.nees_keyframe_motion), 1.5);
  EXPECT_LT(t.trace_ratio, 0.5);
}

TEST(KeyframeIncrementCovariance, TemplateAlignedPixelsFitTheirNoiseModel) {
  // GIVEN pixels as patch refinement makes them: the keyframe-left pixel off by the detector's
  // 0.25 px, the other three following it with an alignment noise of 0.05 px of their own (the
  // keyframe-right one shared by both frames); 1500 trials, so that the mean NEES is known to
  // about 0.1
  PixelNoise noise{0.05, 0.25, true};
  const Trials t = run(1500, true, noise);
  ASSERT_EQ(t.nees_claim.size(), 1500u);
  const double alignment_factor = 0.05 * 0.05 / (kModelSigma * kModelSigma);
  // THEN the claim under the template-aligned noise model finds the alignment's variance in
  // the residuals and fits: mean NEES that of a chi-square with 6 dof
  EXPECT_NEAR(t.variance_factor_mean, alignment_factor, 0.05 * alignment_factor);
  EXPECT_NEAR(mean(t.nees_claim), 6.0, 0.4);
  // WHEN the claim takes all eight pixels as equally and independently noisy instead
  noise.claim_template_aligned = false;
  const Trials iid = run(1500, true, noise);
  ASSERT_EQ(iid.nees_claim.size(), 1500u);
  // THEN it is too tight: the keyframe-left pixel's share of the residual degrees of freedom,
  // counted as noise, lowers the variance it takes by a quarter
  EXPECT_LT(iid.variance_factor_mean, 0.85 * alignment_factor);
  EXPECT_GT(mean(iid.nees_claim), 6.4);
}

}  // namespace
}  // namespace increment_covariance_test
}  // namespace seavio::odometry
