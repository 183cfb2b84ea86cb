#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

#include "core/eval/trajectory_metrics.hpp"
#include "tools/eval_report.hpp"

namespace seavio::tools {
namespace {

std::vector<eval::TimedPose> arc(int n, double scale) {
  std::vector<eval::TimedPose> out;
  for (int i = 0; i < n; ++i) {
    eval::TimedPose p;
    p.t_ns = int64_t(i) * 50'000'000;
    const double a = 0.02 * i;
    p.T_W_B.translation() = scale * Eigen::Vector3d(10 * std::sin(a), 10 - 10 * std::cos(a), 0);
    out.push_back(p);
  }
  return out;
}

std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("seavio_report_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

TEST(EvalReport, TableShowsTableIColumnsAndIncompleteFlag) {
  const auto gt = arc(200, 1.0);
  eval::TrajectoryMetrics m = eval::evaluateTrajectory(gt, arc(200, 1.05));
  std::ostringstream os;
  printMetrics(os, m);
  const std::string s = os.str();
  EXPECT_NE(s.find("Table I"), std::string::npos);
  EXPECT_NE(s.find("ATE RMSE"), std::string::npos);
  char mean[32];
  std::snprintf(mean, sizeof(mean), "%.3f", m.mean_error_m);
  EXPECT_NE(s.find(mean), std::string::npos);
  EXPECT_EQ(s.find("INCOMPLETE"), std::string::npos);

  m = eval::evaluateTrajectory(gt, arc(100, 1.05));
  std::ostringstream os2;
  printMetrics(os2, m);
  EXPECT_NE(os2.str().find("INCOMPLETE"), std::string::npos);
}

TEST(EvalReport, JsonHoldsFiguresAndArrays) {
  const auto gt = arc(100, 1.0);
  const eval::TrajectoryMetrics m = eval::evaluateTrajectory(gt, arc(100, 1.1));
  const std::string path = tempPath("m.json");
  writeMetricsJson(path, m);
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string s = ss.str();
  std::filesystem::remove(path);
  EXPECT_EQ(s.front(), '{');
  EXPECT_NE(s.find("\"incomplete\": false"), std::string::npos);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "\"max_error_m\": %.9g", m.max_error_m);
  EXPECT_NE(s.find(buf), std::string::npos);
  std::snprintf(buf, sizeof(buf), "\"mean_vertical_error_m\": %.9g", m.mean_vertical_error_m);
  EXPECT_NE(s.find(buf), std::string::npos);
  std::snprintf(buf, sizeof(buf), "\"mean_tilt_error_deg\": %.9g", m.mean_tilt_error_deg);
  EXPECT_NE(s.find(buf), std::string::npos);
  std::snprintf(buf, sizeof(buf), "\"heading_step_rms_rad\": %.9g", m.heading_step_rms_rad);
  EXPECT_NE(s.find(buf), std::string::npos);
  std::snprintf(buf, sizeof(buf), "\"heading_step_p90_rad\": %.9g", m.heading_step_p90_rad);
  EXPECT_NE(s.find(buf), std::string::npos);
  std::snprintf(buf, sizeof(buf), "\"heading_steps\": %d,", m.heading_steps);
  EXPECT_NE(s.find(buf), std::string::npos);
  // Per pose: time, distance, error, heading, tilt and the error along W's x, y and z; the
  // 10 % larger arc is off by a tenth of its position, in the plane.
  EXPECT_EQ(std::count(s.begin(), s.end(), '['), 8);
  const double last_error_y = m.est_first_aligned.back().y() - m.gt_position.back().y();
  EXPECT_NEAR(last_error_y, 0.1 * gt.back().T_W_B.translation().y(), 1e-9);
  std::snprintf(buf, sizeof(buf), ", %.9g]", last_error_y);
  const std::size_t y_key = s.find("\"error_y_m\": [");
  ASSERT_NE(y_key, std::string::npos);
  EXPECT_NE(s.find(buf, y_key), std::string::npos);
  EXPECT_THROW(writeMetricsJson("/nonexistent_dir/m.json", m), std::runtime_error);
}

TEST(EvalReport, PlotIsWrittenWithBothCurves) {
  const auto gt = arc(150, 1.0);
  const eval::TrajectoryMetrics m = eval::evaluateTrajectory(gt, arc(150, 1.1));
  const std::string path = tempPath("plot.png");
  writeTrajectoryPlot(path, gt, m.est_first_aligned, m);
  const cv::Mat img = cv::imread(path, cv::IMREAD_COLOR);
  std::filesystem::remove(path);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 1400);
  EXPECT_EQ(img.rows, 650);
  // The estimate is drawn in red (BGR 30, 30, 220), the truth in dark grey.
  int red = 0, dark = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
      red += (p[2] > 180 && p[1] < 80 && p[0] < 80) ? 1 : 0;
      dark += (p[0] < 60 && p[1] < 60 && p[2] < 60) ? 1 : 0;
    }
  EXPECT_GT(red, 500);
  EXPECT_GT(dark, 500);
  EXPECT_THROW(writeTrajectoryPlot("/nonexistent_dir/p.png", gt, m.est_first_aligned, m), std::runtime_error);
}

}  // namespace
}  // namespace seavio::tools
