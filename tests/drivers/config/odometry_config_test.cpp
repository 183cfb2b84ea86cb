#include <algorithm>
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

std::string shippedConfigPath() { return std::string(SEAVIO_SOURCE_DIR) + "/config/seavio.yaml"; }

TEST(OdometryConfig, ReadsValuesOverDefaults) {
  odometry::OdometryParams p;
  const auto errors = parse(
      "odometry: {mode: global, min_inliers: 30, features: {controller: {target_count: 800}},"
      " icp: {max_iterations: 7}, map: {selection_radius_m: 4.5}}",
      p);
  EXPECT_TRUE(errors.empty()) << errors.front();
  EXPECT_EQ(p.mode, odometry::Mode::kGlobal);
  EXPECT_EQ(p.min_inliers, 30);
  EXPECT_EQ(p.features.controller.target_count, 800);
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
  EXPECT_NO_THROW(loadOdometryParamsFile(shippedConfigPath()));
}

/// The leaf keys of a YAML mapping, as dotted paths.
void leafKeys(const YAML::Node& node, const std::string& path, std::vector<std::string>& out) {
  for (const auto& kv : node) {
    const std::string key = path + "." + kv.first.as<std::string>();
    if (kv.second.IsMap()) {
      leafKeys(kv.second, key, out);
    } else {
      out.push_back(key);
    }
  }
}

TEST(OdometryConfig, AtMostSixtyKeysAndTheShippedFileListsEveryOne) {
  // GIVEN the effective configuration of the built-in defaults (`seavio run --print-config`)
  std::vector<std::string> keys;
  leafKeys(YAML::Load(describe(odometry::OdometryParams{})), "odometry", keys);
  // THEN it has at most 60 keys a user sets, and config/seavio.yaml lists each of them
  EXPECT_GE(keys.size(), 40u);
  EXPECT_LE(keys.size(), 60u);
  std::vector<std::string> shipped;
  leafKeys(YAML::LoadFile(shippedConfigPath())["odometry"], "odometry", shipped);
  std::sort(keys.begin(), keys.end());
  std::sort(shipped.begin(), shipped.end());
  EXPECT_EQ(shipped, keys);
}

TEST(OdometryConfig, TheShippedFileSaysWhatTheBuiltInDefaultsAre) {
  // `seavio run` without --config uses the built-ins, the daemon and the docs config/seavio.yaml:
  // a default changed in one place only would make the two run different filters.
  const odometry::OdometryParams shipped = loadOdometryParamsFile(shippedConfigPath());
  EXPECT_EQ(describe(shipped), describe(odometry::OdometryParams{}));
}

/// The message of the InputError thrown by loadOdometryParamsFile for `text`, or "" if none.
std::string loadError(const std::string& text, const std::string& name) {
  const std::string path = testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  try {
    loadOdometryParamsFile(path);
  } catch (const drivers::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(OdometryConfigBadInput, EveryErrorNamesTheFileAndTheKey) {
  struct Case {
    const char* text;
    const char* key;  ///< expected in the message after the path
  };
  const Case cases[] = {
      {"daemon: {}\n", "odometry: missing section"},
      {"- odometry\n", "odometry: missing section"},
      {"odometry: [1, 2]\n", "odometry: expected a mapping"},
      {"odometry: {icp: 5}\n", "odometry.icp: expected a mapping"},
      {"odometry: {icp: {max_iterations: 1.5}}\n", "odometry.icp.max_iterations: expected an integer"},
      {"odometry: {ransac: {inlier_threshold_px: [0.9]}}\n", "odometry.ransac.inlier_threshold_px: expected a number"},
      {"odometry: {stereo: {completion: {enabled: maybe}}}\n",
       "odometry.stereo.completion.enabled: expected true or false"},
      {"odometry: {map: {keyframe_distance_m: .nan}}\n", "odometry.map.keyframe_distance_m"},
      {"odometry: {prediction: {a: 1}}\n", "odometry.prediction"},
      {"odometry: {features: {controller: {target_count: 5000, max_count: 3000}}}\n", "odometry.features: "},
      {"odometry: {min_inliers: 10\n", "line"},
  };
  int i = 0;
  for (const Case& c : cases) {
    const std::string name = "bad" + std::to_string(i++) + ".yaml";
    const std::string msg = loadError(c.text, name);
    EXPECT_NE(msg.find(name), std::string::npos) << c.text << " -> " << msg;
    EXPECT_NE(msg.find(c.key), std::string::npos) << c.text << " -> " << msg;
  }
}

TEST(OdometryConfigBadInput, NonScalarKeyIsAnErrorNotAnException) {
  // Found by fuzz_odometry_config: a list used as a key escaped as YAML::TypedBadConversion
  // (seaviod swallowed it and ran with the rest of the section unchecked).
  const std::string msg = loadError("odometry:\n  icp:\n    [a, b]: 1\n  ? {c: 1}\n  : 2\n", "key.yaml");
  EXPECT_NE(msg.find("key.yaml: odometry.icp: a key must be a plain name (line 3)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("key.yaml: odometry: a key must be a plain name (line 4)"), std::string::npos) << msg;
  odometry::OdometryParams p;
  std::vector<std::string> errors;
  EXPECT_NO_THROW(parseOdometryParams(YAML::Load("{[1]: 2}"), "x.yaml", p, errors));
  EXPECT_EQ(errors.size(), 1u);
}


TEST(OdometryConfig, TheAuvProfileIsTheBuiltInDefaultsAndTheCarProfileOnlyChangesTheRig) {
  // `seavio run` without --config is `--config config/profiles/auv-downward.yaml`.
  const std::string profiles = std::string(SEAVIO_SOURCE_DIR) + "/config/profiles/";
  EXPECT_EQ(describe(loadOdometryParamsFile(profiles + "auv-downward.yaml")), describe(odometry::OdometryParams{}));
  // A profile is the rig only: everything else keeps the defaults.
  const odometry::OdometryParams car = loadOdometryParamsFile(profiles + "car-forward.yaml");
  odometry::OdometryParams expected;
  expected.rig = car.rig;
  EXPECT_EQ(describe(car), describe(expected));
  EXPECT_GT(car.rig.max_speed_m_s, odometry::OdometryParams{}.rig.max_speed_m_s);
  // Its stereo search is everything the rig triangulates.
  EXPECT_EQ(car.rig.scene_min_depth_m, 0.0);
  EXPECT_EQ(car.rig.scene_max_depth_m, 0.0);
}

}  // namespace
}  // namespace seavio::config
