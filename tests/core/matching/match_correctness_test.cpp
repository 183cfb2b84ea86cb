#include <gtest/gtest.h>

#include "core/matching/match_correctness.hpp"

namespace seavio::matching {
namespace {

camera::RectifiedRig rig640() {
  camera::RectifiedRig rig;
  rig.width = 640;
  rig.height = 480;
  rig.f_px = 554.0;
  rig.cx = 320;
  rig.cy = 240;
  rig.baseline_m = 0.32;
  return rig;
}

StereoPoint seen(const camera::RectifiedRig& rig, const Eigen::Vector3d& p_R0) {
  StereoPoint sp;
  sp.uv_left = rig.project(p_R0, 0).cast<float>();
  sp.uv_right = rig.project(p_R0, 1).cast<float>();
  sp.p_R0 = p_R0.cast<float>();
  return sp;
}

TEST(MatchCorrectness, CountsOnlyMatchesConsistentWithTheTrueMotion) {
  // GIVEN three floor points seen before and after a known motion
  const auto rig = rig640();
  const Eigen::Isometry3d T_prev_curr =
      Eigen::Translation3d(0.15, 0.02, 0.01) * Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ());
  const std::vector<Eigen::Vector3d> world{{0.3, 0.2, 4.0}, {-0.5, 0.1, 4.2}, {0.1, -0.4, 3.9}};
  StereoFeatures prev, curr;
  for (const auto& p : world) {
    prev.points.push_back(seen(rig, p));
    curr.points.push_back(seen(rig, T_prev_curr.inverse() * p));
  }
  // WHEN two matches are right, one pairs the wrong points and one points out of range
  const std::vector<TemporalMatch> matches{{0, 0, 0.f}, {1, 1, 0.f}, {2, 0, 0.f}, {2, 7, 0.f}};
  const MatchCorrectness c = judgeMatches(prev, curr, matches, rig, T_prev_curr);
  // THEN only the two right ones count
  EXPECT_EQ(c.matches, 4);
  EXPECT_EQ(c.correct, 2);
  EXPECT_DOUBLE_EQ(c.precision(), 0.5);
  // AND against a wrong motion (10 cm off) none of them is correct
  const Eigen::Isometry3d wrong = Eigen::Translation3d(0.1, 0, 0) * T_prev_curr;
  EXPECT_EQ(judgeMatches(prev, curr, matches, rig, wrong).correct, 0);
}

}  // namespace
}  // namespace seavio::matching
