// Rectification through our own fixed-point remap (no per-call buffers) must give
// exactly cv::remap's bytes on the same maps, at the image borders as much as inside.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera/remap_bilinear.hpp"

namespace seavio::camera {
namespace {

/// Random grey image with the full 0..255 range (smooth parts would hide rounding errors).
cv::Mat noiseImage(int w, int h, uint32_t seed) {
  cv::Mat img(h, w, CV_8UC1);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> v(0, 255);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.at<uint8_t>(y, x) = static_cast<uint8_t>(v(rng));
  return img;
}

struct Difference {
  int pixels = 0;   ///< pixels that differ
  int largest = 0;  ///< largest absolute difference [grey levels]
};

Difference compare(const cv::Mat& a, const cv::Mat& b) {
  Difference d;
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x) {
      const int e = std::abs(int(a.at<uint8_t>(y, x)) - int(b.at<uint8_t>(y, x)));
      if (e > 0) ++d.pixels;
      d.largest = std::max(d.largest, e);
    }
  return d;
}

/// Pixels whose map point lies in the outer band or outside the source (border handling).
int borderPixels(const cv::Mat& mx, const cv::Mat& my, int w, int h) {
  int n = 0;
  for (int y = 0; y < mx.rows; ++y)
    for (int x = 0; x < mx.cols; ++x) {
      const float u = mx.at<float>(y, x), v = my.at<float>(y, x);
      if (u < 1 || v < 1 || u > w - 2 || v > h - 2) ++n;
    }
  return n;
}

TEST(RemapBilinear, EqualsCvRemapOnUndistortionMapsWithBlackBorders) {
  // GIVEN a strongly distorted camera rectified with a rotation and a wider output, so many
  // output pixels sample the source's edge or beyond it
  const int w = 331, h = 217;  // odd sizes: the 8-pixel steps leave a tail in each row
  const cv::Matx33d K(260, 0, 160, 0, 255, 110, 0, 0, 1);
  const std::vector<double> D{-0.35, 0.12, 0.001, -0.002};
  cv::Mat rvec = (cv::Mat_<double>(3, 1) << 0.03, -0.05, 0.08), Rm;
  cv::Rodrigues(rvec, Rm);
  const cv::Matx33d P(140, 0, 175, 0, 140, 115, 0, 0, 1);
  cv::Mat mx, my, xy, frac;
  cv::initUndistortRectifyMap(K, D, Rm, P, cv::Size(w + 20, h + 10), CV_32FC1, mx, my);
  cv::convertMaps(mx, my, xy, frac, CV_16SC2);
  ASSERT_GT(borderPixels(mx, my, w, h), 2000);
  for (uint32_t seed : {1u, 2u, 3u}) {
    const cv::Mat src = noiseImage(w, h, seed);
    // WHEN remapped by ours (into a reused output) and by OpenCV
    cv::Mat ours, theirs;
    remapBilinear(src, ours, xy, frac);
    cv::remap(src, theirs, xy, frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
    // THEN every pixel is equal
    ASSERT_EQ(ours.size(), theirs.size());
    const Difference d = compare(ours, theirs);
    EXPECT_EQ(d.pixels, 0) << "seed " << seed << ", largest difference " << d.largest;
    EXPECT_LE(d.largest, 1);
  }
}

TEST(RemapBilinear, EqualsCvRemapForEveryFractionAndEdgeCase) {
  // GIVEN maps that visit all 1,024 sub-pixel fractions at random points in and around the
  // source: inside, on the last row and column, half outside (-1), wholly outside
  const int w = 64, h = 48, mw = 256, mh = 96;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> ux(-3.f, w + 2.f), uy(-3.f, h + 2.f);
  cv::Mat mx(mh, mw, CV_32FC1), my(mh, mw, CV_32FC1);
  for (int y = 0; y < mh; ++y)
    for (int x = 0; x < mw; ++x) {
      const int k = y * mw + x;
      const float fx = static_cast<float>(k % 32) / 32.f, fy = static_cast<float>((k / 32) % 32) / 32.f;
      const float bx = std::floor(ux(rng)), by = std::floor(uy(rng));
      mx.at<float>(y, x) = bx + fx;
      my.at<float>(y, x) = by + fy;
    }
  // the exact edges as well: -1, 0, w - 2, w - 1 in x and y
  const float edges_x[] = {-1.f, -0.5f, 0.f, w - 2.f, w - 1.5f, w - 1.f, w - 0.25f};
  const float edges_y[] = {-1.f, -0.5f, 0.f, h - 2.f, h - 1.5f, h - 1.f, h - 0.25f};
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j) {
      mx.at<float>(0, i * 7 + j) = edges_x[i];
      my.at<float>(0, i * 7 + j) = edges_y[j];
    }
  cv::Mat xy, frac;
  cv::convertMaps(mx, my, xy, frac, CV_16SC2);
  ASSERT_GT(borderPixels(mx, my, w, h), mw * mh / 10);
  cv::Mat ours;
  for (uint32_t seed : {11u, 12u, 13u, 14u}) {
    // A source that is a view into a larger image (row step > width), and a constant border
    // other than black.
    const cv::Mat big = noiseImage(w + 9, h + 3, seed);
    const cv::Mat src = big(cv::Rect(5, 2, w, h));
    const uint8_t border = seed == 14 ? 200 : 0;
    // WHEN remapped into the same output Mat each time
    const uchar* before = ours.data;
    remapBilinear(src, ours, xy, frac, border);
    cv::Mat theirs;
    cv::remap(src, theirs, xy, frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(border));
    // THEN byte-equal, and the output buffer is reused once it has the maps' size
    const Difference d = compare(ours, theirs);
    EXPECT_EQ(d.pixels, 0) << "seed " << seed << ", largest difference " << d.largest;
    if (before) {
      EXPECT_EQ(ours.data, before);
    }
  }
}

TEST(RemapBilinear, NonGreyImagesAndAliasedOutputFallBackToCvRemap) {
  // GIVEN a 3-channel image and an identity-plus-shift map
  cv::Mat mx(20, 30, CV_32FC1), my(20, 30, CV_32FC1);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 30; ++x) {
      mx.at<float>(y, x) = x + 0.3f;
      my.at<float>(y, x) = y - 0.6f;
    }
  cv::Mat xy, frac;
  cv::convertMaps(mx, my, xy, frac, CV_16SC2);
  cv::Mat colour(20, 30, CV_8UC3);
  cv::randu(colour, cv::Scalar::all(0), cv::Scalar::all(256));
  cv::Mat ours, theirs;
  // WHEN remapped
  remapBilinear(colour, ours, xy, frac);
  cv::remap(colour, theirs, xy, frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  // THEN the result is OpenCV's
  ASSERT_EQ(ours.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0.0);
  // AND an output that is the input itself gives the same as a separate output
  cv::Mat grey = noiseImage(30, 20, 5), expected;
  remapBilinear(grey, expected, xy, frac);
  cv::Mat in_place = grey.clone();
  remapBilinear(in_place, in_place, xy, frac);
  EXPECT_EQ(cv::norm(in_place, expected, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace seavio::camera
