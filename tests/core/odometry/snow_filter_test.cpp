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
  // WHEN the snow filter runs with its default 5 px disc
  cv::Mat out;
  suppressSnow(img, out, SnowFilterParams{});
  // THEN the dot is gone, the pebble's centre and the dark pit are untouched
  EXPECT_EQ(out.at<uint8_t>(30, 30), 100);
  EXPECT_EQ(out.at<uint8_t>(60, 100), 200);
  EXPECT_EQ(out.at<uint8_t>(100, 60), 20);
  // AND disabled, it is an exact copy
  cv::Mat copy;
  suppressSnow(img, copy, SnowFilterParams{false, 5});
  EXPECT_EQ(cv::norm(copy, img, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace snow_filter_test
}  // namespace seavio::odometry
