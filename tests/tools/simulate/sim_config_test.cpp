#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <stdexcept>

#include "tools/simulate/seafloor_renderer.hpp"
#include "tools/simulate/sim_config.hpp"
#include "tools/simulate/stereo_rig_model.hpp"

namespace seavio::simulate {
namespace {

using ::testing::HasSubstr;

TEST(SimConfig, PresetsAreValidAndMatchThePaper) {
  for (const auto& name : presetNames()) EXPECT_NO_THROW(validate(presetConfig(name))) << name;
  const SimConfig paper = presetConfig("paper-snow");
  EXPECT_EQ(paper.frames, 3000);
  EXPECT_EQ(paper.rig.width, 640);
  EXPECT_EQ(paper.rig.height, 480);
  EXPECT_DOUBLE_EQ(paper.rig.hfov_deg, 60.0);
  EXPECT_DOUBLE_EQ(paper.rig.baseline_m, 0.32);
  EXPECT_DOUBLE_EQ(paper.trajectory.altitude_m, 4.0);
  EXPECT_EQ(paper.trajectory.legs, 5);
  EXPECT_TRUE(paper.snow.enabled);
  EXPECT_FALSE(presetConfig("paper-plain").snow.enabled);
  EXPECT_FALSE(presetConfig("short-plain").snow.enabled);
  EXPECT_TRUE(presetConfig("short-snow").snow.enabled);
  EXPECT_DOUBLE_EQ(presetConfig("short-plain").frame_rate_hz, 10.0);
}

TEST(SimConfig, UnknownPresetNamesTheValidOnes) {
  try {
    presetConfig("paper-fog");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("paper-fog"));
    EXPECT_THAT(e.what(), HasSubstr("short-plain"));
  }
}

TEST(SimConfig, BadParametersAreAllNamed) {
  SimConfig c = presetConfig("short-plain");
  c.imu.rate_hz = 50;
  c.frames = 0;
  c.rig.tilt_deg = 75;
  c.trajectory.speed_m_s = -1;
  try {
    validate(c);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("imu-rate"));
    EXPECT_THAT(e.what(), HasSubstr("frames"));
    EXPECT_THAT(e.what(), HasSubstr("tilt-deg"));
    EXPECT_THAT(e.what(), HasSubstr("speed"));
  }
}

TEST(SimConfig, ValidationSeedsAreRefusedOutsideTheValidationSuite) {
  // GIVEN a tuning configuration (what tests and `seavio simulate` build) on a validation seed.
  SimConfig c = presetConfig("short-plain");
  c.seed = kValidationSeeds.first;
  try {
    validate(c);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("validation seed"));
    EXPECT_THAT(e.what(), HasSubstr(validationSeedRangeText()));
  }
  // The renderer refuses it too, for callers that skip validate().
  c.seed = kValidationSeeds.last;
  EXPECT_THROW(SeafloorRenderer(c, StereoRigModel(c.rig)), std::invalid_argument);
  // Just outside the range is a tuning seed.
  c.seed = kValidationSeeds.last + 1;
  EXPECT_NO_THROW(validate(c));
  // The validation suite's configurations take validation seeds and nothing else.
  c.seed_use = SeedUse::kValidation;
  EXPECT_THROW(validate(c), std::invalid_argument);
  c.seed = kValidationSeeds.first;
  EXPECT_NO_THROW(validate(c));
}

}  // namespace
}  // namespace seavio::simulate
