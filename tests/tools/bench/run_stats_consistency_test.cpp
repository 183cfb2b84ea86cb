// What a frame's estimate claims, in the stats JSON: the filter's bias sigmas on every frame,
// the increment's covariance only on a visual increment.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "tests/tools/bench/stats_json_text.hpp"
#include "tools/run_stats.hpp"

namespace seavio::tools {

TEST(RunStatsConsistency, BiasSigmasOnEveryFrameAndTheIncrementCovarianceOnVisualOnes) {
  RunStats stats;
  OdometryResult coasted;
  coasted.gyro_bias_sigma_rad_s = Eigen::Vector3d(1e-4, 2e-4, 3e-4);
  coasted.accel_bias_sigma_m_s2 = Eigen::Vector3d(0.01, 0.02, 0.03);
  OdometryResult visual = coasted;
  for (int k = 0; k < 6; ++k) visual.increment_covariance(k, k) = 1e-6 * (k + 1);
  visual.increment_covariance(0, 5) = visual.increment_covariance(5, 0) = 7e-8;
  stats.add(coasted);
  stats.add(visual);
  const std::string s = testing::statsJsonText(stats, "run_stats_consistency");
  const std::string sigma_text =
      "\"gyro_bias_sigma_rad_s\": [1.0000e-04, 2.0000e-04, 3.0000e-04], "
      "\"accel_bias_sigma_m_s2\": [1.0000e-02, 2.0000e-02, 3.0000e-02]";
  std::size_t sigmas = 0;
  for (std::size_t p = s.find(sigma_text); p != std::string::npos; p = s.find(sigma_text, p + 1)) ++sigmas;
  EXPECT_EQ(sigmas, 2u) << s;
  // One increment_cov, the upper triangle row by row: (0,0) .. (0,5), then (1,1) ..
  EXPECT_EQ(s.find("\"increment_cov\""), s.rfind("\"increment_cov\""));
  EXPECT_NE(s.find("\"increment_cov\": [1.000000e-06, 0.000000e+00, 0.000000e+00, 0.000000e+00, 0.000000e+00, "
                   "7.000000e-08, 2.000000e-06, "),
            std::string::npos)
      << s;
  EXPECT_NE(s.find("6.000000e-06]"), std::string::npos) << s;
}

}  // namespace seavio::tools
