// Replay regression, as flight stacks keep one: a short simulated survey (tuning seed) run with
// the shipped defaults must reproduce the pinned trajectory, pose by pose, within a tolerance
// far below any accuracy figure but above floating-point noise between builds (Release,
// sanitizers). A change that moves it fails here, intended or not.
//
// An intended change updates the pin IN THE SAME COMMIT:
//   SEAVIO_UPDATE_PIN=1 build/tests/tools/regression/test_tools_regression --gtest_filter='PinnedTrajectory.*'
// rewrites tests/data/pinned/short-plain-seed5-60.tum in the source tree (the test then fails
// once, saying so); rerun it without the variable, check `git diff --stat` shows the pin, and put
// the accuracy change (seavio eval before/after) in the commit message.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/eval/trajectory_metrics.hpp"
#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/tum_io.hpp"
#include "tools/sequence_runner.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio {
namespace pinned_trajectory_test {
namespace {

namespace fs = std::filesystem;

const fs::path kPin = fs::path(SEAVIO_SOURCE_DIR) / "tests/data/pinned/short-plain-seed5-60.tum";
constexpr double kPositionTolM = 1e-3;
constexpr double kAngleTolRad = 1e-4;

/// 60 frames (6 s at 10 Hz) of short-plain, seed 5: the start-up from rest, the speed ramp and
/// steady flight, in local mode with every default.
std::vector<eval::TimedPose> replay() {
  simulate::SimConfig c = simulate::presetConfig("short-plain");
  c.seed = 5;
  c.frames = 60;
  const fs::path dir = fs::temp_directory_path() / "seavio_pinned_short-plain-seed5-60";
  simulate::writeSequence(c, dir.string(), true);
  const drivers::Dataset ds = drivers::loadEuroc(dir.string());
  return tools::runSequence(ds, config::loadOdometryParamsFile("")).trajectory;
}

TEST(PinnedTrajectory, ShortSurveyReproducesThePin) {
  const std::vector<eval::TimedPose> now = replay();
  ASSERT_EQ(now.size(), 60u);
  if (const char* update = std::getenv("SEAVIO_UPDATE_PIN"); update && std::string(update) == "1") {
    drivers::writeTum(kPin.string(), now);
    FAIL() << "pin rewritten: " << kPin << "; commit it with the change, rerun without SEAVIO_UPDATE_PIN";
  }
  ASSERT_TRUE(fs::exists(kPin)) << kPin << " missing (see the top of this file to make it)";
  const std::vector<eval::TimedPose> pin = drivers::readTum(kPin.string());
  ASSERT_EQ(pin.size(), now.size());
  double worst_m = 0, worst_rad = 0;
  std::size_t first_off = now.size();
  for (std::size_t i = 0; i < now.size(); ++i) {
    ASSERT_EQ(now[i].t_ns, pin[i].t_ns) << "frame " << i;
    const double dp = (now[i].T_W_B.translation() - pin[i].T_W_B.translation()).norm();
    const double da = Eigen::AngleAxisd(now[i].T_W_B.linear() * pin[i].T_W_B.linear().transpose()).angle();
    worst_m = std::max(worst_m, dp);
    worst_rad = std::max(worst_rad, da);
    if ((dp > kPositionTolM || da > kAngleTolRad) && first_off == now.size()) first_off = i;
  }
  EXPECT_LE(worst_m, kPositionTolM) << "first frame off the pin: " << first_off;
  EXPECT_LE(worst_rad, kAngleTolRad) << "first frame off the pin: " << first_off;
  // The pin is a real trajectory, not a resting one: the survey moved.
  EXPECT_GT((pin.back().T_W_B.translation() - pin.front().T_W_B.translation()).norm(), 1.0);
}

}  // namespace
}  // namespace pinned_trajectory_test
}  // namespace seavio
