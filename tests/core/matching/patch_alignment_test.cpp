#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "core/matching/patch_alignment.hpp"
#include "tests/core/matching/sand_texture.hpp"

namespace seavio::matching {
namespace {

cv::Mat texture(int seed, int size = 240) { return test::sandTexture(seed, cv::Size(size, size)); }

/// `ref` moved by the affine map p -> A p + t (floating point, then 8 bit), grey levels
/// scaled by `gain`, raised by `offset`, with Gaussian noise of `noise_dn`.
cv::Mat moved(const cv::Mat& ref, const Eigen::Matrix2f& A, const Eigen::Vector2f& t, double gain, double offset,
              double noise_dn, int seed) {
  cv::Mat f, w;
  ref.convertTo(f, CV_32F);
  const cv::Mat M = (cv::Mat_<double>(2, 3) << A(0, 0), A(0, 1), t.x(), A(1, 0), A(1, 1), t.y());
  cv::warpAffine(f, w, M, ref.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  cv::Mat noise(ref.size(), CV_32F);
  cv::RNG rng(static_cast<uint64_t>(seed));
  rng.fill(noise, cv::RNG::NORMAL, 0, noise_dn);
  w = w * gain + offset + noise;
  cv::Mat out;
  w.convertTo(out, CV_8U);
  return out;
}

TEST(PatchAlignment, RecoversASubPixelShiftUnderGainOffsetAndNoise) {
  // GIVEN a textured image moved by (3.37, -1.81) px, 30 % darker, +15 grey levels, noise 1.5
  const cv::Mat ref = texture(1);
  const Eigen::Vector2f t(3.37f, -1.81f);
  const cv::Mat img = moved(ref, Eigen::Matrix2f::Identity(), t, 0.7, 15, 1.5, 2);
  // WHEN twenty points are aligned from a start 0.6-1 px off the truth
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(60.f, 180.f), off(-0.7f, 0.7f);
  int ok = 0;
  double start_total = 0;
  std::vector<double> errors;
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector2f p(u(rng), u(rng)), truth = p + t;
    const Eigen::Vector2f start = truth + Eigen::Vector2f(off(rng), off(rng));
    start_total += (start - truth).norm();
    const PatchAlignment a = alignPatch(ref, p, img, start, Eigen::Matrix2f::Identity(), PatchAlignParams{});
    if (!a.ok) continue;
    ++ok;
    errors.push_back((a.uv - truth).norm());
    EXPECT_GT(a.zncc, 0.95f);
  }
  // THEN every point is accepted, half within 0.06 px and all within 0.12 px, where the
  // starts were ~0.5 px off (what is left is mostly bilinear sampling's pull towards whole
  // pixels, ~0.03 px here without any noise)
  ASSERT_EQ(ok, 20);
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[10], 0.06);
  EXPECT_LT(errors.back(), 0.12);
  EXPECT_GT(start_total / 20, 0.3);
}

/// `clean` with bright blurred dots as marine snow leaves them after its filter (the brightest
/// are filled in, the dimmer ones stay): ~1 per 15 x 15 patch, sigma 0.8 px, +60 grey levels.
cv::Mat withSnowDots(const cv::Mat& clean, std::mt19937& rng) {
  cv::Mat f;
  clean.convertTo(f, CV_32F);
  std::uniform_real_distribution<float> where(0.f, static_cast<float>(clean.cols - 1));
  for (std::size_t k = 0; k < clean.total() / 225; ++k) {
    const float x = where(rng), y = where(rng);
    for (int v = std::max(0, int(y) - 3); v <= std::min(clean.rows - 1, int(y) + 3); ++v)
      for (int u = std::max(0, int(x) - 3); u <= std::min(clean.cols - 1, int(x) + 3); ++u)
        f.at<float>(v, u) += 60.f * std::exp(-((u - x) * (u - x) + (v - y) * (v - y)) / (2 * 0.8f * 0.8f));
  }
  cv::Mat out;
  f.convertTo(out, CV_8U);
  return out;
}

TEST(PatchAlignment, TheHuberWeightsKeepSnowDotsInOnePatchFromPullingTheShift) {
  // GIVEN three textured images moved by a sub-pixel shift, each also with snow dots
  PatchAlignParams least_squares;
  least_squares.huber = 0;
  least_squares.min_zncc = 0;  // compare the same points
  PatchAlignParams huber = least_squares;
  huber.huber = PatchAlignParams{}.huber;
  ASSERT_GT(huber.huber, 0);
  const Eigen::Vector2f t(1.23f, 0.61f);
  std::vector<double> pull_ls, pull_huber;  // how far the dots moved each alignment [px]
  for (int seed = 0; seed < 3; ++seed) {
    const cv::Mat ref = texture(40 + seed);
    const cv::Mat clean = moved(ref, Eigen::Matrix2f::Identity(), t, 1.0, 0, 1.0, 50 + seed);
    std::mt19937 rng(static_cast<unsigned>(60 + seed));
    const cv::Mat snowy = withSnowDots(clean, rng);
    // WHEN 200 points of each are aligned with and without the dots, by least squares and
    // with the Huber weights
    std::uniform_real_distribution<float> u(30.f, 210.f);
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector2f p(u(rng), u(rng)), truth = p + t;
      const PatchAlignment a0 = alignPatch(ref, p, clean, truth, Eigen::Matrix2f::Identity(), least_squares);
      const PatchAlignment a1 = alignPatch(ref, p, snowy, truth, Eigen::Matrix2f::Identity(), least_squares);
      const PatchAlignment b0 = alignPatch(ref, p, clean, truth, Eigen::Matrix2f::Identity(), huber);
      const PatchAlignment b1 = alignPatch(ref, p, snowy, truth, Eigen::Matrix2f::Identity(), huber);
      if (!a0.ok || !a1.ok || !b0.ok || !b1.ok) continue;
      pull_ls.push_back((a1.uv - a0.uv).norm());
      pull_huber.push_back((b1.uv - b0.uv).norm());
    }
  }
  // THEN the dots move the weighted alignments less, median and upper decile
  ASSERT_GT(pull_ls.size(), 450u);
  std::sort(pull_ls.begin(), pull_ls.end());
  std::sort(pull_huber.begin(), pull_huber.end());
  const std::size_t p90 = pull_ls.size() * 9 / 10, mid = pull_ls.size() / 2;
  RecordProperty("pull_median_ls_px", std::to_string(pull_ls[mid]));
  RecordProperty("pull_median_huber_px", std::to_string(pull_huber[mid]));
  RecordProperty("pull_p90_ls_px", std::to_string(pull_ls[p90]));
  RecordProperty("pull_p90_huber_px", std::to_string(pull_huber[p90]));
  EXPECT_LT(pull_huber[mid], 0.75 * pull_ls[mid]) << pull_huber[mid] << " vs " << pull_ls[mid];
  EXPECT_LT(pull_huber[p90], 0.75 * pull_ls[p90]) << pull_huber[p90] << " vs " << pull_ls[p90];
}

TEST(PatchAlignment, FollowsTheMotionsInPlaneTurnAndScale) {
  // GIVEN the image turned by 6 deg and scaled by 1.03 about the origin, then shifted
  const cv::Mat ref = texture(4);
  const float a = 6.f * static_cast<float>(M_PI) / 180.f;
  const Eigen::Matrix2f A = 1.03f * Eigen::Rotation2Df(a).toRotationMatrix();
  const Eigen::Vector2f t(12.f, -9.f);
  const cv::Mat img = moved(ref, A, t, 1.0, 0, 1.0, 5);
  const Eigen::Vector2f p(130.f, 110.f), truth = A * p + t;
  const Eigen::Vector2f start = truth + Eigen::Vector2f(0.6f, -0.5f);
  // WHEN aligned with the motion's A, and with the identity
  const PatchAlignment with = alignPatch(ref, p, img, start, A, PatchAlignParams{});
  PatchAlignParams big;
  big.half_size_px = 12;  // a larger patch, where the unmodelled turn shows more
  const PatchAlignment without = alignPatch(ref, p, img, start, Eigen::Matrix2f::Identity(), big);
  // THEN the warped patch lands on the truth; the unwarped one is off or refused
  ASSERT_TRUE(with.ok);
  EXPECT_LT((with.uv - truth).norm(), 0.06f);
  EXPECT_GT(with.zncc, without.zncc);
}

TEST(PatchAlignment, RefusesEdgesFlatPatchesOtherPlacesAndBorders) {
  const cv::Mat ref = texture(6);
  const Eigen::Matrix2f I = Eigen::Matrix2f::Identity();
  const PatchAlignParams p;
  // Stripes (a ripple crest without grain): only across them is the position fixed.
  cv::Mat stripes(200, 200, CV_8U);
  for (int y = 0; y < stripes.rows; ++y)
    for (int x = 0; x < stripes.cols; ++x)
      stripes.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(128 + 60 * std::sin(2 * M_PI * x / 14.0));
  EXPECT_FALSE(alignPatch(stripes, {100.f, 100.f}, stripes, {100.3f, 100.4f}, I, p).ok);
  // Flat grey: nothing to align.
  const cv::Mat flat(200, 200, CV_8U, cv::Scalar(90));
  EXPECT_FALSE(alignPatch(flat, {100.f, 100.f}, flat, {100.f, 100.f}, I, p).ok);
  // Another texture altogether: the correlation stays low, or the shift runs away.
  const cv::Mat other = texture(7);
  EXPECT_FALSE(alignPatch(ref, {100.f, 100.f}, other, {100.f, 100.f}, I, p).ok);
  // A patch reaching over the border, in either image.
  EXPECT_FALSE(alignPatch(ref, {3.f, 100.f}, ref, {100.f, 100.f}, I, p).ok);
  EXPECT_FALSE(alignPatch(ref, {100.f, 100.f}, ref, {100.f, 236.f}, I, p).ok);
  // The same texture at the same place is accepted where it starts.
  const PatchAlignment same = alignPatch(ref, {100.f, 100.f}, ref, {100.f, 100.f}, I, p);
  ASSERT_TRUE(same.ok);
  EXPECT_LT((same.uv - Eigen::Vector2f(100.f, 100.f)).norm(), 1e-3f);
  EXPECT_NEAR(same.zncc, 1.f, 1e-4f);
}

}  // namespace
}  // namespace seavio::matching
