// The `revisit` preset (memory follows the area, not the time): 10,000 frames, most of
// them over ground the first pass already mapped.
#include <gtest/gtest.h>

#include <vector>

#include "tools/simulate/seafloor.hpp"
#include "tools/simulate/sim_config.hpp"
#include "tools/simulate/trajectory.hpp"

namespace seavio::simulate {
namespace {

TEST(RevisitPreset, FliesTheFirstPassAgainAndAgain) {
  const SimConfig c = presetConfig("revisit");
  ASSERT_NO_THROW(validate(c));
  EXPECT_EQ(c.frames, 10000);
  EXPECT_EQ(c.rig.width, 640);
  EXPECT_EQ(c.rig.height, 480);
  const ReliefField relief{c.seafloor, c.seed};
  const double duration = (c.frames - 1) / c.frame_rate_hz;
  const Trajectory traj{c.trajectory, relief, duration};
  // Positions at 1 Hz: the first 80 s are the first pass (short-plain: lane 0, turn, lane 1).
  std::vector<Eigen::Vector2d> first, later;
  for (int t = 0; t <= static_cast<int>(duration); ++t)
    (t < 80 ? first : later).push_back(traj.at(t).p_W.head<2>());
  // The box stays 40 m x 8 m (plus the turns).
  for (const auto& p : later) {
    EXPECT_GT(p.x(), -8.0);
    EXPECT_LT(p.x(), 48.0);
    EXPECT_GT(p.y(), -8.0);
    EXPECT_LT(p.y(), 16.0);
  }
  // Ground already mapped: within 1 m (under a third of the 3.5 m footprint) of the first
  // pass, sampled every 1 m (83 % of the later frames). The rest: the end of lane 1 and the
  // turns at the start end, which the first 80 s never reached.
  int over_mapped = 0;
  for (const auto& p : later) {
    double best = 1e9;
    for (const auto& q : first) best = std::min(best, (p - q).norm());
    over_mapped += best <= 1.0;
  }
  EXPECT_GE(over_mapped, static_cast<int>(0.8 * static_cast<double>(later.size())))
      << over_mapped << " of " << later.size();
  EXPECT_GT(later.size(), 900u);
  // And it is the short-plain survey, only longer.
  SimConfig s = presetConfig("short-plain");
  EXPECT_EQ(s.trajectory.legs, c.trajectory.legs);
  EXPECT_DOUBLE_EQ(s.trajectory.leg_length_m, c.trajectory.leg_length_m);
  EXPECT_DOUBLE_EQ(s.trajectory.leg_spacing_m, c.trajectory.leg_spacing_m);
}

}  // namespace
}  // namespace seavio::simulate
