// RippleNotch: the dominant periodic texture found and notched out, broadband texture kept,
// and the point of it: a sliding periodic shading no longer pulls the measured image motion.
#include "core/odometry/ripple_notch.hpp"

#include <algorithm>
#include <vector>

#include <Eigen/Core>

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/matching/patch_alignment.hpp"

namespace seavio::odometry {
namespace {

constexpr int kW = 320, kH = 240;

/// Broadband "albedo": smoothed noise, zero mean, ~25 DN standard deviation.
cv::Mat grain(uint32_t seed) {
  cv::Mat noise(kH, kW, CV_32F);
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.f, 1.f);
  for (int r = 0; r < kH; ++r)
    for (int c = 0; c < kW; ++c) noise.at<float>(r, c) = n(rng);
  cv::GaussianBlur(noise, noise, {0, 0}, 1.5, 0, cv::BORDER_REFLECT);
  cv::Scalar mean, sd;
  cv::meanStdDev(noise, mean, sd);
  return (noise - mean[0]) * (25.0 / sd[0]);
}

/// Ripple shading: a sinusoid of `period_px` along direction `theta`, shifted by `shift_px`
/// along it, with its second harmonic (a lit flank is not a pure sine).
cv::Mat ripples(double period_px, double theta, double shift_px, double amplitude) {
  cv::Mat s(kH, kW, CV_32F);
  const double kx = std::cos(theta) * 2 * M_PI / period_px, ky = std::sin(theta) * 2 * M_PI / period_px;
  const double phase = shift_px * 2 * M_PI / period_px;
  for (int r = 0; r < kH; ++r)
    for (int c = 0; c < kW; ++c) {
      const double a = kx * c + ky * r - phase;
      s.at<float>(r, c) = static_cast<float>(amplitude * (std::sin(a) + 0.35 * std::sin(2 * a + 0.7)));
    }
  return s;
}

cv::Mat to8u(const cv::Mat& f) {
  cv::Mat u;
  cv::Mat(f + 110.0).convertTo(u, CV_8U);
  return u;
}

/// Correlation coefficient of two images (float).
double correlation(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat fa, fb;
  a.convertTo(fa, CV_64F);
  b.convertTo(fb, CV_64F);
  fa -= cv::mean(fa)[0];
  fb -= cv::mean(fb)[0];
  return fa.dot(fb) / std::sqrt(fa.dot(fa) * fb.dot(fb));
}

/// Median motion from `a` to `b` of 15 x 15 patches on a grid, as the patch refinement measures
/// it (core/matching/patch_alignment.hpp), starting from the floor's true motion.
Eigen::Vector2f motion(const cv::Mat& a, const cv::Mat& b, float true_dx) {
  matching::PatchAlignParams params;
  params.min_zncc = 0.5;
  std::vector<float> dx, dy;
  for (int y = 24; y < kH - 24; y += 12)
    for (int x = 24; x < kW - 24; x += 12) {
      const Eigen::Vector2f ref(static_cast<float>(x), static_cast<float>(y));
      const matching::PatchAlignment al =
          matching::alignPatch(a, ref, b, ref + Eigen::Vector2f(true_dx, 0), Eigen::Matrix2f::Identity(), params);
      if (!al.ok) continue;
      dx.push_back(al.uv.x() - ref.x());
      dy.push_back(al.uv.y() - ref.y());
    }
  EXPECT_GT(dx.size(), 100u);
  std::nth_element(dx.begin(), dx.begin() + static_cast<std::ptrdiff_t>(dx.size() / 2), dx.end());
  std::nth_element(dy.begin(), dy.begin() + static_cast<std::ptrdiff_t>(dy.size() / 2), dy.end());
  return {dx[dx.size() / 2], dy[dy.size() / 2]};
}

TEST(RippleNotch, FindsThePeriodAndRemovesItKeepingTheGrain) {
  const double period = 12.5, theta = 0.6;
  const cv::Mat g = grain(3);
  const cv::Mat rip = ripples(period, theta, 0, 30);
  const cv::Mat img = to8u(g + rip);
  RippleNotchParams p;
  p.enabled = true;
  RippleNotch notch(p);
  cv::Mat out;
  const RippleNotchReport rep = notch.apply(img, out);
  ASSERT_TRUE(rep.applied);
  EXPECT_NEAR(rep.period_px, period, 0.05 * period);
  // The wave vector's direction up to its sign (the search keeps one half of the spectrum).
  const double d = std::remainder(rep.direction_rad - theta, M_PI);
  EXPECT_LT(std::abs(d), 0.05);
  EXPECT_GT(rep.peak_ratio, p.min_peak_ratio);
  // Before: the image is mostly ripples; after: mostly grain, little ripple left.
  EXPECT_GT(std::abs(correlation(img, rip)), 0.6);
  EXPECT_LT(std::abs(correlation(out, rip)), 0.1);
  EXPECT_GT(correlation(out, g), 0.9);
}

TEST(RippleNotch, LeavesAFloorWithoutADominantPeriodAlone) {
  const cv::Mat img = to8u(grain(5));
  RippleNotchParams p;
  p.enabled = true;
  RippleNotch notch(p);
  cv::Mat out;
  const RippleNotchReport rep = notch.apply(img, out);
  EXPECT_FALSE(rep.applied);
  EXPECT_LT(rep.peak_ratio, p.min_peak_ratio);
  EXPECT_EQ(cv::norm(img, out, cv::NORM_INF), 0.0);
  // Disabled: a copy, nothing searched.
  RippleNotchParams disabled;
  disabled.enabled = false;
  RippleNotch off(disabled);
  cv::Mat copy;
  const cv::Mat rippled = to8u(grain(5) + ripples(12.5, 0.3, 0, 30));
  EXPECT_FALSE(off.apply(rippled, copy).applied);
  EXPECT_EQ(cv::norm(rippled, copy, cv::NORM_INF), 0.0);
}

TEST(RippleNotch, SlidingShadingNoLongerPullsTheMotion) {
  // The floor moves 4 px along x between two images; the lit ripples' shading moves only
  // 2.5 px (it slides back with the lights; exaggerated against the simulator's ~0.6 % of the
  // motion so that one image pair shows it). Measured by patch alignment on the raw images
  // the motion is pulled towards the shading's; on the notched ones it is the floor's.
  const double true_shift = 4.0, shading_shift = 2.5, period = 12.5, theta = 0.2;
  const cv::Mat g0 = grain(7);
  cv::Mat g1;
  const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, true_shift, 0, 1, 0);
  cv::warpAffine(g0, g1, m, g0.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  const cv::Mat a = to8u(g0 + ripples(period, theta, 0, 30));
  const cv::Mat b = to8u(g1 + ripples(period, theta, shading_shift * std::cos(theta), 30));  // x by s: s cos(theta) along k
  RippleNotchParams p;
  p.enabled = true;
  RippleNotch notch(p);
  cv::Mat na, nb;
  ASSERT_TRUE(notch.apply(a, na).applied);
  ASSERT_TRUE(notch.apply(b, nb).applied);
  const double raw_error = std::abs(motion(a, b, true_shift).x() - true_shift);
  const double notched_error = std::abs(motion(na, nb, true_shift).x() - true_shift);
  EXPECT_GT(raw_error, 0.3);
  EXPECT_LT(notched_error, 0.15);
  EXPECT_LT(notched_error, 0.3 * raw_error);
}

}  // namespace
}  // namespace seavio::odometry
