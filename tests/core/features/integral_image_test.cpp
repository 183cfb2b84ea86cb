#include "core/features/integral_image.hpp"

#include <random>

#include <gtest/gtest.h>

namespace seavio::features {
namespace {

TEST(IntegralImage, BoxSumsMatchBruteForce) {
  // GIVEN a random 8-bit image
  std::mt19937 rng(7);
  cv::Mat img(37, 53, CV_8UC1);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) img.at<uint8_t>(y, x) = static_cast<uint8_t>(rng() % 256);
  // WHEN its integral image is built
  const IntegralImage ii(img);
  ASSERT_EQ(ii.width(), 53);
  ASSERT_EQ(ii.height(), 37);
  EXPECT_EQ(ii.at(0, 0), 0u);
  EXPECT_EQ(ii.at(53, 0), 0u);
  // THEN every random box sum equals the brute-force sum
  std::uniform_int_distribution<int> ux(0, 53), uy(0, 37);
  for (int t = 0; t < 500; ++t) {
    int x0 = ux(rng), x1 = ux(rng), y0 = uy(rng), y1 = uy(rng);
    if (x0 > x1) std::swap(x0, x1);
    if (y0 > y1) std::swap(y0, y1);
    uint32_t expected = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) expected += img.at<uint8_t>(y, x);
    ASSERT_EQ(ii.boxSum(x0, y0, x1, y1), expected) << x0 << "," << y0 << "," << x1 << "," << y1;
  }
  EXPECT_EQ(ii.at(53, 37), static_cast<uint32_t>(cv::sum(img)[0]));
}

TEST(IntegralImage, EveryEntryMatchesRunningSumsAtEveryWidth) {
  // GIVEN random images of widths around the 16-pixel steps of the vectorised row sums, one a
  // view into a larger image (row pitch > width)
  std::mt19937 rng(11);
  IntegralImage ii;
  for (int w : {1, 2, 15, 16, 17, 31, 32, 33, 47, 64, 65}) {
    cv::Mat img(7, w, CV_8UC1);
    for (int y = 0; y < img.rows; ++y)
      for (int x = 0; x < img.cols; ++x) img.at<uint8_t>(y, x) = static_cast<uint8_t>(rng() % 256);
    if (w == 33) {  // the same values, seen through a view with a wider row pitch
      cv::Mat big(9, 80, CV_8UC1, cv::Scalar(255));
      img.copyTo(big(cv::Rect(5, 1, w, img.rows)));
      img = big(cv::Rect(5, 1, w, img.rows));
      ASSERT_FALSE(img.isContinuous());
    }
    // WHEN its table is built (reusing one object, so the buffer is reused too)
    ii.compute(img);
    // THEN every entry is the plain running sum
    for (int y = 0; y <= img.rows; ++y) {
      for (int x = 0; x <= w; ++x) {
        uint32_t expected = 0;
        for (int yy = 0; yy < y; ++yy)
          for (int xx = 0; xx < x; ++xx) expected += img.at<uint8_t>(yy, xx);
        ASSERT_EQ(ii.at(x, y), expected) << "width " << w << " at " << x << "," << y;
      }
    }
  }
}

TEST(IntegralImage, BoxesOutsideTheImageAreClipped) {
  const cv::Mat img(10, 10, CV_8UC1, cv::Scalar(3));
  const IntegralImage ii(img);
  EXPECT_EQ(ii.boxSum(-5, -5, 2, 2), 12u);
  EXPECT_EQ(ii.boxSum(8, 8, 50, 50), 12u);
  EXPECT_EQ(ii.boxSum(20, 20, 30, 30), 0u);
  EXPECT_EQ(ii.boxSum(5, 5, 5, 9), 0u);
}

TEST(IntegralImage, WrappedTableStillGivesExactBoxSums) {
  // GIVEN an all-white image whose total (4400 x 4000 x 255) exceeds 2^32
  const cv::Mat img(4000, 4400, CV_8UC1, cv::Scalar(255));
  const IntegralImage ii(img);
  // THEN a box far down the table, past the wrap, is still exact
  EXPECT_EQ(ii.boxSum(4300, 3900, 4400, 4000), 100u * 100u * 255u);
}

TEST(IntegralImage, RejectsColourImages) {
  const cv::Mat colour(4, 4, CV_8UC3, cv::Scalar(1, 2, 3));
  IntegralImage ii;
  EXPECT_FALSE(ii.compute(colour));
  // AND it reads as an empty image, never out of its table
  EXPECT_EQ(ii.width(), 0);
  EXPECT_EQ(ii.boxSum(0, 0, 4, 4), 0u);
  EXPECT_TRUE(ii.compute(cv::Mat(4, 4, CV_8UC1, cv::Scalar(2))));
  EXPECT_EQ(ii.boxSum(0, 0, 4, 4), 32u);
}

}  // namespace
}  // namespace seavio::features

// The table is not zero-filled on reuse: a rebuild for a smaller (then larger) image must
// still give the same table as a fresh object, borders included.
TEST(IntegralImage, ReuseForAnotherSizeEqualsAFreshTable) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> grey(0, 255);
  auto random = [&](int w, int h) {
    cv::Mat m(h, w, CV_8UC1);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) m.at<uint8_t>(y, x) = static_cast<uint8_t>(grey(rng));
    return m;
  };
  seavio::features::IntegralImage reused(random(40, 30));
  for (const cv::Size size : {cv::Size(17, 11), cv::Size(40, 30), cv::Size(5, 60)}) {
    const cv::Mat img = random(size.width, size.height);
    reused.compute(img);
    const seavio::features::IntegralImage fresh(img);
    ASSERT_EQ(reused.width(), size.width);
    ASSERT_EQ(reused.height(), size.height);
    for (int y = 0; y <= size.height; ++y)
      for (int x = 0; x <= size.width; ++x) ASSERT_EQ(reused.at(x, y), fresh.at(x, y)) << x << "," << y;
    EXPECT_EQ(reused.boxSum(0, 0, size.width, size.height), static_cast<uint32_t>(cv::sum(img)[0]));
  }
}
