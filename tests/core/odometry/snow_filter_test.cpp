#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/odometry/frontend.hpp"

namespace seavio::odometry {
namespace snow_filter_test {
namespace {

TEST(SnowFilter, RemovesSmallBrightDotsAndKeepsLargerFloorStructure) {
  // GIVEN a grey floor with a 3 px snow dot, a 20 px bright pebble and a 3 px dark pit
  cv::Mat img(120, 160, CV_8UC1, cv::Scalar(100));
  cv::circle(img, {30, 30}, 1, cv::Scalar(255), cv::FILLED);
  cv::circle(img, {100, 60}, 10, cv::Scalar(200), cv::FILLED);
  cv::circle(img, {60, 100}, 1, cv::Scalar(20), cv::FILLED);
  // WHEN the snow filter runs as the plain opening (the default, 5 px disc), and opening only the dots
  for (const SnowFilterParams& params : {SnowFilterParams{}, SnowFilterParams{true, 5, 255, 40}}) {
    cv::Mat out;
    suppressSnow(img, out, params);
    // THEN the dot is gone, the pebble's centre and the dark pit are untouched
    EXPECT_EQ(out.at<uint8_t>(30, 30), 100);
    EXPECT_EQ(out.at<uint8_t>(60, 100), 200);
    EXPECT_EQ(out.at<uint8_t>(100, 60), 20);
  }
  // AND disabled, it is an exact copy
  cv::Mat copy;
  suppressSnow(img, copy, SnowFilterParams{false, 5, 255, 30});
  EXPECT_EQ(cv::norm(copy, img, cv::NORM_INF), 0.0);
}

TEST(SnowFilter, KeepsTheFloorsFineTextureAndTakesTheDotWithItsHalo) {
  // GIVEN a grey floor with fine bright texture (1 px specks 6 and 25 DN above it, narrower
  // than the disc: a plain opening flattens them) and a 3 px snow dot with a 1 px halo
  cv::Mat img(120, 160, CV_8UC1, cv::Scalar(100));
  for (int y = 10; y < 110; y += 7)
    for (int x = 10; x < 150; x += 9) img.at<uint8_t>(y, x) = static_cast<uint8_t>(x % 2 ? 125 : 106);
  cv::circle(img, {31, 33}, 2, cv::Scalar(115), cv::FILLED);  // the halo: 15 DN, under dot_dn
  cv::circle(img, {31, 33}, 1, cv::Scalar(255), cv::FILLED);
  const SnowFilterParams params{true, 5, 255, 40};  // dots above 40 DN opened, everything else untouched
  cv::Mat out;
  suppressSnow(img, out, params);
  // THEN every speck is untouched, and the dot and its halo take the floor's grey
  EXPECT_EQ(out.at<uint8_t>(10, 10), 106);
  EXPECT_EQ(out.at<uint8_t>(10, 19), 125);
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx) EXPECT_EQ(out.at<uint8_t>(33 + dy, 31 + dx), 100) << dx << "," << dy;
  cv::Mat opened;
  suppressSnow(img, opened, SnowFilterParams{true, 5, 0, 30});
  EXPECT_EQ(opened.at<uint8_t>(10, 10), 100);  // (the plain opening does flatten them)
  // AND keeping up to 8 DN away from dots cuts the 25 DN speck to 8 and leaves the 6 DN one
  cv::Mat kept;
  suppressSnow(img, kept, SnowFilterParams{true, 5, 8, 30});
  EXPECT_EQ(kept.at<uint8_t>(10, 10), 106);
  EXPECT_EQ(kept.at<uint8_t>(10, 19), 108);
  // AND the reused filter, in place, gives the same image
  SnowFilter filter(params);
  cv::Mat inplace = img.clone();
  filter.apply(inplace, inplace);
  EXPECT_EQ(cv::norm(inplace, out, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace snow_filter_test
}  // namespace seavio::odometry
