#include "core/geometry/quadrifocal_ransac.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/geometry/quadrifocal.hpp"
#include "synthetic_scene.hpp"

namespace seavio::geometry {
namespace {

using testing::makeMotion;
using testing::makeRig;
using testing::makeScene;
using testing::rotationError;
using testing::translationError;

constexpr double kDeg = M_PI / 180.0;

/// An IMU prediction of motion `T`: off by 3 cm and 1 degree.
Eigen::Isometry3d imuLikePrior(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d prior = T;
  prior.translation() += Eigen::Vector3d(0.03, -0.01, 0.0);
  prior.linear() = prior.linear() * Eigen::AngleAxisd(1 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return prior;
}

bool allFinite(const RansacResult& r) {
  return r.T_prev_curr.matrix().allFinite() && r.covariance.allFinite() && std::isfinite(r.rms_px);
}

TEST(QuadrifocalRansac, ExactRecoveryOnNoiselessData) {
  // GIVEN noiseless matches of a known motion and an identity prior
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  std::mt19937 rng(1);
  const auto scene = makeScene(rig, T, 60, 0.0, 0.0, rng);
  QuadrifocalRansac ransac(rig, {});
  // WHEN estimated
  const RansacResult r = ransac.estimate(scene.matches, Eigen::Isometry3d::Identity(), rng);
  // THEN the motion is exact (float pixels limit it) and every match is an inlier
  ASSERT_EQ(r.status, RansacStatus::kOk);
  EXPECT_LT(rotationError(r.T_prev_curr, T), 1e-5 * kDeg);
  EXPECT_LT(translationError(r.T_prev_curr, T), 1e-6);
  EXPECT_EQ(r.inliers.size(), scene.matches.size());
  EXPECT_LT(r.rms_px, 1e-3);
  // AND the tensor of the estimate satisfies the quadrilinear constraints of every match
  // (to the float precision of the pixels)
  const QuadrifocalTensor Q(quadCameras(rig, r.T_prev_curr));
  for (const QuadMatch& m : scene.matches)
    EXPECT_LT(Q.relativeResidual(m.left_prev.cast<double>(), m.right_prev.cast<double>(),
                                 m.left_curr.cast<double>(), m.right_curr.cast<double>()),
              1e-7);
}

TEST(QuadrifocalRansac, RecoversMotionFromNoisyMatchesWithHalfOutliers) {
  // GIVEN 100 matches at 4 m altitude, 0.3 px noise, 50% wrong temporal matches, and a
  // prior off by 3 cm and 1 degree (an IMU prediction)
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  const Eigen::Isometry3d prior = imuLikePrior(T);
  QuadRansacParams params;
  params.prior_max_translation_m = 0.2;
  params.prior_max_rotation_rad = 5 * kDeg;
  QuadrifocalRansac ransac(rig, params);
  ransac.reserve(100);
  std::vector<double> rot_err, trans_err;
  for (uint32_t seed = 1; seed <= 11; ++seed) {
    std::mt19937 rng(seed);
    const auto scene = makeScene(rig, T, 100, 0.5, 0.3, rng);
    // WHEN estimated
    const RansacResult r = ransac.estimate(scene.matches, prior, rng);
    // THEN the inliers are found, few outliers let in, the residual is the pixel noise
    ASSERT_EQ(r.status, RansacStatus::kOk) << "seed " << seed;
    int true_in = 0, false_in = 0;
    for (uint32_t i : r.inliers) (scene.is_inlier[i] ? true_in : false_in)++;
    EXPECT_GE(true_in, 45) << "seed " << seed;
    EXPECT_LE(false_in, 2) << "seed " << seed;
    EXPECT_GT(r.rms_px, 0.2);
    EXPECT_LT(r.rms_px, 0.45);
    EXPECT_TRUE(allFinite(r));
    rot_err.push_back(rotationError(r.T_prev_curr, T));
    trans_err.push_back(translationError(r.T_prev_curr, T));
  }
  // AND the motion is within 0.1 degree and 1 cm (median over runs; single runs scatter by
  // the Cramer-Rao bound of 50 inliers at 0.3 px, ~0.07 degree in roll and pitch, which
  // trade against x/y translation over a flat floor), never worse than 0.25 degree / 2 cm.
  std::sort(rot_err.begin(), rot_err.end());
  std::sort(trans_err.begin(), trans_err.end());
  EXPECT_LT(rot_err[rot_err.size() / 2], 0.1 * kDeg);
  EXPECT_LT(trans_err[trans_err.size() / 2], 0.01);
  EXPECT_LT(rot_err.back(), 0.25 * kDeg);
  EXPECT_LT(trans_err.back(), 0.02);
}

TEST(QuadrifocalRansac, CovarianceMatchesTheActualError) {
  // GIVEN many noisy trials of the same motion
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  QuadrifocalRansac ransac(rig, {});
  double nees = 0;
  const int trials = 40;
  for (int k = 0; k < trials; ++k) {
    std::mt19937 rng(100 + k);
    const auto scene = makeScene(rig, T, 80, 0.2, 0.3, rng);
    const RansacResult r = ransac.estimate(scene.matches, T, rng);
    ASSERT_EQ(r.status, RansacStatus::kOk);
    // Left perturbation: T_true = exp(d) T_est.
    const Eigen::Isometry3d D = T * r.T_prev_curr.inverse();
    Eigen::Matrix<double, 6, 1> d;
    const Eigen::AngleAxisd aa(D.linear());
    d.head<3>() = aa.angle() * aa.axis();
    d.tail<3>() = D.translation();
    const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(r.covariance);
    ASSERT_EQ(llt.info(), Eigen::Success);
    nees += d.dot(llt.solve(d));
  }
  // THEN the normalised estimation error squared averages ~6 (6 DoF): the covariance is
  // neither wildly optimistic nor pessimistic
  nees /= trials;
  EXPECT_GT(nees, 2.0);
  EXPECT_LT(nees, 15.0);
}

TEST(QuadrifocalRansac, TensorOfTheEstimateSatisfiesInlierConstraints) {
  // GIVEN an estimate from noisy data with outliers
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  std::mt19937 rng(9);
  const auto scene = makeScene(rig, T, 100, 0.5, 0.3, rng);
  QuadrifocalRansac ransac(rig, {});
  const RansacResult r = ransac.estimate(scene.matches, Eigen::Isometry3d::Identity(), rng);
  ASSERT_EQ(r.status, RansacStatus::kOk);
  // WHEN the explicit tensor is built from it
  const QuadrifocalTensor Q(quadCameras(rig, r.T_prev_curr));
  // THEN the quadrilinear residuals of the inliers are much smaller than the outliers'
  double worst_in = 0;
  std::vector<double> out;
  std::vector<bool> is_in(scene.matches.size(), false);
  for (uint32_t i : r.inliers) is_in[i] = true;
  for (std::size_t i = 0; i < scene.matches.size(); ++i) {
    const QuadMatch& m = scene.matches[i];
    const double e = Q.relativeResidual(m.left_prev.cast<double>(), m.right_prev.cast<double>(),
                                        m.left_curr.cast<double>(), m.right_curr.cast<double>());
    if (is_in[i]) worst_in = std::max(worst_in, e);
    else if (!scene.is_inlier[i]) out.push_back(e);
  }
  ASSERT_FALSE(out.empty());
  std::sort(out.begin(), out.end());
  EXPECT_LT(worst_in, out[out.size() / 2] / 5);
}

TEST(QuadrifocalRansac, BadInputGivesAStatusNeverNaN) {
  const auto rig = makeRig();
  QuadrifocalRansac ransac(rig, {});
  std::mt19937 rng(5);
  const Eigen::Isometry3d prior = makeMotion();
  // Empty and too few.
  {
    const RansacResult r = ransac.estimate({}, prior, rng);
    EXPECT_EQ(r.status, RansacStatus::kTooFewMatches);
    EXPECT_TRUE(r.T_prev_curr.isApprox(prior));
  }
  auto scene = makeScene(rig, prior, 40, 0.0, 0.3, rng);
  {
    const RansacResult r = ransac.estimate(std::span(scene.matches).first(2), prior, rng);
    EXPECT_EQ(r.status, RansacStatus::kTooFewMatches);
  }
  // Zero or negative disparity everywhere: nothing can be triangulated.
  {
    auto bad = scene.matches;
    for (auto& m : bad) m.right_prev = m.left_prev + Eigen::Vector2f(1.0f, 0.0f);
    const RansacResult r = ransac.estimate(bad, prior, rng);
    EXPECT_EQ(r.status, RansacStatus::kTooFewMatches);
    EXPECT_TRUE(allFinite(r));
  }
  // NaN and inf pixels.
  {
    auto bad = scene.matches;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (std::size_t i = 0; i < bad.size(); i += 2) bad[i].left_curr.x() = nan;
    for (std::size_t i = 1; i < bad.size(); i += 4) bad[i].right_prev.y() = std::numeric_limits<float>::infinity();
    const RansacResult r = ransac.estimate(bad, Eigen::Isometry3d::Identity(), rng);
    EXPECT_TRUE(allFinite(r));
  }
  // The same match repeated: every sample is degenerate.
  {
    std::vector<QuadMatch> same(30, scene.matches[0]);
    const RansacResult r = ransac.estimate(same, Eigen::Isometry3d::Identity(), rng);
    EXPECT_NE(r.status, RansacStatus::kOk);
    EXPECT_TRUE(allFinite(r));
  }
  // A non-finite prior is ignored, not propagated.
  {
    Eigen::Isometry3d nan_prior = prior;
    nan_prior.translation().x() = std::numeric_limits<double>::quiet_NaN();
    const RansacResult r = ransac.estimate(scene.matches, nan_prior, rng);
    EXPECT_EQ(r.status, RansacStatus::kOk);
    EXPECT_TRUE(allFinite(r));
  }
  // Pure noise: no consensus.
  {
    std::uniform_real_distribution<float> u(0, 600), d(2, 60);
    std::vector<QuadMatch> noise(60);
    for (auto& m : noise) {
      m.left_prev = {u(rng), u(rng) * 0.8f};
      m.right_prev = m.left_prev - Eigen::Vector2f(d(rng), 0);
      m.left_curr = {u(rng), u(rng) * 0.8f};
      m.right_curr = m.left_curr - Eigen::Vector2f(d(rng), 0);
    }
    const RansacResult r = ransac.estimate(noise, Eigen::Isometry3d::Identity(), rng);
    EXPECT_EQ(r.status, RansacStatus::kNoConsensus);
    EXPECT_TRUE(allFinite(r));
  }
}

TEST(QuadrifocalRansac, PriorRadiusRejectsFarHypotheses) {
  // GIVEN a correct motion but a prior 1 m away with a 10 cm radius
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  std::mt19937 rng(21);
  const auto scene = makeScene(rig, T, 60, 0.0, 0.3, rng);
  Eigen::Isometry3d prior = T;
  prior.translation().x() += 1.0;
  QuadRansacParams params;
  params.prior_max_translation_m = 0.1;
  QuadrifocalRansac ransac(rig, params);
  // THEN no hypothesis is allowed and the result falls back to the prior
  const RansacResult r = ransac.estimate(scene.matches, prior, rng);
  EXPECT_EQ(r.status, RansacStatus::kNoConsensus);
  EXPECT_TRUE(r.T_prev_curr.isApprox(prior));
  // AND without the radius the same data is solved
  QuadrifocalRansac free(rig, {});
  EXPECT_EQ(free.estimate(scene.matches, prior, rng).status, RansacStatus::kOk);
}

TEST(QuadrifocalRansac, StatusNames) {
  EXPECT_STREQ(toString(RansacStatus::kOk), "ok");
  EXPECT_STREQ(toString(RansacStatus::kNoConsensus), "no_consensus");
}

// Reuse: estimate() into a RansacResult kept across frames gives what a fresh result gives,
// whatever the previous call left in it (a success with many inliers, a failure).
TEST(QuadrifocalRansac, ReusedResultEqualsAFreshOne) {
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  QuadrifocalRansac reused(rig, {}), fresh(rig, {});
  RansacResult kept;
  // GIVEN scenes of changing size and outlier rate, one too small to estimate
  for (const auto& [n, outliers] : std::vector<std::pair<int, double>>{{120, 0.3}, {8, 0.0}, {60, 0.5}, {200, 0.1}}) {
    std::mt19937 scene_rng(static_cast<uint32_t>(n));
    const auto scene = makeScene(rig, T, n, outliers, 0.3, scene_rng);
    // WHEN estimated into the kept result and into a fresh one, same random streams
    std::mt19937 rng_a(7), rng_b(7);
    reused.estimate(scene.matches, T, rng_a, kept);
    const RansacResult r = fresh.estimate(scene.matches, T, rng_b);
    // THEN every field is identical
    EXPECT_EQ(kept.status, r.status) << n;
    EXPECT_EQ(kept.inliers, r.inliers) << n;
    EXPECT_EQ(kept.T_prev_curr.matrix(), r.T_prev_curr.matrix()) << n;
    EXPECT_EQ(kept.covariance, r.covariance) << n;
    EXPECT_EQ(kept.rms_px, r.rms_px) << n;
    EXPECT_EQ(kept.iterations, r.iterations) << n;
    if (n >= 60) {
      EXPECT_EQ(r.status, RansacStatus::kOk) << n;
    } else {
      EXPECT_NE(r.status, RansacStatus::kOk) << n;
    }
  }
}

TEST(QuadrifocalRansac, ReselectTakesBackMatchesOnceTheirPixelsAreRefined) {
  // GIVEN 100 matches, 30% wrong, with SURF-like localisation noise (0.5 px per coordinate, so
  // the largest of four transfer errors often exceeds the 1.5 px threshold), and the same
  // matches as patch refinement leaves the true ones (0.1 px; the wrong ones unchanged)
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  QuadrifocalRansac ransac(rig, {});
  std::vector<double> err_first, err_reselected;
  for (uint32_t seed = 1; seed <= 9; ++seed) {
    std::mt19937 coarse_rng(seed), fine_rng(seed);
    const auto coarse = makeScene(rig, T, 100, 0.3, 0.5, coarse_rng);
    const auto fine = makeScene(rig, T, 100, 0.3, 0.1, fine_rng);
    ASSERT_EQ(coarse.is_inlier, fine.is_inlier);  // one scene, two noise levels
    std::vector<QuadMatch> refined = coarse.matches;
    for (std::size_t i = 0; i < refined.size(); ++i)
      if (coarse.is_inlier[i]) refined[i] = fine.matches[i];
    std::mt19937 rng(seed);
    RansacResult r = ransac.estimate(coarse.matches, Eigen::Isometry3d::Identity(), rng);
    ASSERT_EQ(r.status, RansacStatus::kOk) << "seed " << seed;
    const std::size_t first_inliers = r.inliers.size();
    err_first.push_back(rotationError(r.T_prev_curr, T));
    // WHEN the inliers are re-selected from the refined pixels under RANSAC's motion
    ransac.reselect(refined, r);
    // THEN the true matches the noise had kept out come back, the wrong ones stay out
    ASSERT_EQ(r.status, RansacStatus::kOk) << "seed " << seed;
    int true_in = 0, false_in = 0;
    for (uint32_t i : r.inliers) (coarse.is_inlier[i] ? true_in : false_in)++;
    EXPECT_LT(first_inliers, 60u) << "seed " << seed;  // the noise costs RANSAC matches
    EXPECT_GE(true_in, 68) << "seed " << seed;         // of 70
    EXPECT_EQ(false_in, 0) << "seed " << seed;
    EXPECT_LT(r.rms_px, 0.2) << "seed " << seed;
    EXPECT_TRUE(allFinite(r));
    err_reselected.push_back(rotationError(r.T_prev_curr, T));
    // AND a tighter threshold holds the refined pixels but not SURF's
    RansacResult tight = r, coarse_tight = r;
    ransac.reselect(refined, tight, 0.6);
    ransac.reselect(coarse.matches, coarse_tight, 0.6);
    EXPECT_GE(tight.inliers.size(), 66u) << "seed " << seed;
    EXPECT_LT(coarse_tight.inliers.size(), first_inliers / 2) << "seed " << seed;
  }
  // AND the rotation is several times closer to the truth (medians over the seeds)
  std::nth_element(err_first.begin(), err_first.begin() + 4, err_first.end());
  std::nth_element(err_reselected.begin(), err_reselected.begin() + 4, err_reselected.end());
  EXPECT_LT(err_reselected[4], err_first[4] / 3);
}

TEST(QuadrifocalRansac, ReselectFromAFailedMotionReportsNoConsensus) {
  // GIVEN matches and a motion that explains none of them
  const auto rig = makeRig();
  std::mt19937 rng(3);
  const auto scene = makeScene(rig, makeMotion(), 60, 0.0, 0.3, rng);
  RansacResult r;
  r.T_prev_curr = Eigen::Isometry3d(Eigen::Translation3d(1.0, 0.5, 0.0));
  r.inliers = {1, 2, 3};
  // WHEN re-selected
  QuadrifocalRansac(rig, {}).reselect(scene.matches, r);
  // THEN nothing passes: no consensus, no inliers, nothing NaN
  EXPECT_EQ(r.status, RansacStatus::kNoConsensus);
  EXPECT_TRUE(r.inliers.empty());
  EXPECT_TRUE(r.T_prev_curr.matrix().allFinite());
}

/// A ParallelFor on three threads of its own, each taking every third index from the top: the
/// jobs run concurrently and out of order, as on any pool.
class ThreeThreads final : public ParallelFor {
 public:
  void run(std::size_t n, const std::function<void(std::size_t)>& job) override {
    ++runs;
    std::vector<std::thread> threads;
    for (std::size_t t = 0; t < 3; ++t)
      threads.emplace_back([&, t] {
        for (std::size_t k = t; k < n; k += 3) job(n - 1 - k);
      });
    for (auto& th : threads) th.join();
  }
  int runs = 0;
};

TEST(QuadrifocalRansac, HypothesesOnAParallelForGiveTheSequentialResult) {
  // GIVEN scenes from few to most matches wrong, with and without a prior window (the
  // adaptive stop then falls anywhere inside a batch, or at the iteration cap)
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  const Eigen::Isometry3d prior = imuLikePrior(T);
  for (const double outliers : {0.2, 0.5, 0.8})
    for (const bool window : {false, true})
      for (uint32_t seed = 1; seed <= 6; ++seed) {
        QuadRansacParams params;
        if (window) {
          params.prior_max_translation_m = 0.2;
          params.prior_max_rotation_rad = 5 * kDeg;
        }
        std::mt19937 scene_rng(seed);
        const auto scene = makeScene(rig, T, 100, outliers, 0.3, scene_rng);
        QuadrifocalRansac sequential(rig, params), parallel(rig, params);
        ThreeThreads threads;
        parallel.setParallelFor(&threads);
        std::mt19937 rng_s(seed), rng_p(seed);
        // WHEN estimated on the caller's thread and on the three threads
        const RansacResult a = sequential.estimate(scene.matches, prior, rng_s);
        const RansacResult b = parallel.estimate(scene.matches, prior, rng_p);
        // THEN the batches ran on the threads, and every output is the same to the bit, down to
        // the generator's state for whatever draws from it next
        const std::string at = "outliers " + std::to_string(outliers) + " window " + std::to_string(window) +
                               " seed " + std::to_string(seed);
        EXPECT_GT(threads.runs, 0) << at;
        EXPECT_EQ(a.status, b.status) << at;
        EXPECT_EQ(a.iterations, b.iterations) << at;
        EXPECT_EQ(a.inliers, b.inliers) << at;
        EXPECT_TRUE(a.T_prev_curr.matrix() == b.T_prev_curr.matrix()) << at;
        EXPECT_EQ(rng_s(), rng_p()) << at;
      }
}

}  // namespace
}  // namespace seavio::geometry
