#include <fstream>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/dataset.hpp"

namespace seavio::config {
namespace {

std::vector<std::string> parse(const std::string& text, odometry::OdometryParams& p) {
  std::vector<std::string> errors;
  parseOdometryParams(YAML::Load(text)["odometry"], "test.yaml", p, errors);
  return errors;
}

TEST(OdometryConfig, ReadsValuesOverDefaults) {
  odometry::OdometryParams p;
  const auto errors = parse(
      "odometry: {mode: global, min_inliers: 30, features: {type: orb, controller: {target_count: 800}},"
      " icp: {max_iterations: 7}, map: {selection_radius_m: 4.5}}",
      p);
  EXPECT_TRUE(errors.empty()) << errors.front();
  EXPECT_EQ(p.mode, odometry::Mode::kGlobal);
  EXPECT_EQ(p.min_inliers, 30);
  EXPECT_EQ(p.features.type, features::DetectorType::kOrb);
  // Switching detector switches to its own threshold range; the explicit target stays.
  EXPECT_EQ(p.features.controller.target_count, 800);
  EXPECT_EQ(p.features.controller.max_threshold, features::defaultThresholdRange(features::DetectorType::kOrb).max);
  EXPECT_EQ(p.icp.max_iterations, 7);
  EXPECT_DOUBLE_EQ(p.map.selection_radius_m, 4.5);
}

TEST(OdometryConfig, ReportsEveryErrorWithFileAndKey) {
  odometry::OdometryParams p;
  const auto errors = parse(
      "odometry: {mode: sideways, min_inliers: two, stereo: {ratio: 3}, icp: {max_iteratons: 5}, extra: 1}", p);
  ASSERT_EQ(errors.size(), 5u);
  const std::string all = errors[0] + errors[1] + errors[2] + errors[3] + errors[4];
  for (const char* needle : {"test.yaml", "odometry.mode", "odometry.min_inliers", "odometry.stereo.ratio",
                             "odometry.icp.max_iteratons: unknown key", "odometry.extra: unknown key"})
    EXPECT_NE(all.find(needle), std::string::npos) << needle << " not in\n" << all;
  EXPECT_EQ(p.min_inliers, odometry::OdometryParams{}.min_inliers);  // bad values leave defaults
}

TEST(OdometryConfig, DescribeRoundTrips) {
  odometry::OdometryParams p;
  p.mode = odometry::Mode::kGlobal;
  p.temporal.sigma_multiplier = 4.25;
  odometry::OdometryParams back;
  std::vector<std::string> errors;
  parseOdometryParams(YAML::Load(describe(p)), "described", back, errors);
  EXPECT_TRUE(errors.empty());
  EXPECT_EQ(back.mode, odometry::Mode::kGlobal);
  EXPECT_DOUBLE_EQ(back.temporal.sigma_multiplier, 4.25);
  EXPECT_EQ(describe(back), describe(p));
}

TEST(OdometryConfig, FileErrorsThrowWithThePath) {
  EXPECT_THROW(loadOdometryParamsFile("/nonexistent/seavio.yaml"), drivers::InputError);
  const std::string path = testing::TempDir() + "/bad.yaml";
  std::ofstream(path) << "odometry: {min_inliers: [1, 2]\n";
  try {
    loadOdometryParamsFile(path);
    FAIL() << "expected an InputError";
  } catch (const drivers::InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
  }
  // The shipped default configuration is valid.
  EXPECT_NO_THROW(loadOdometryParamsFile(std::string(SEAVIO_SOURCE_DIR) + "/config/seavio.yaml"));
}

}  // namespace
}  // namespace seavio::config
