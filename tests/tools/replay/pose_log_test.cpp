// GIVEN an LCM log of seaviod's poses (with status and other channels mixed in), THEN the
// trajectory read back equals what was published and evaluates to zero error against it.
#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>

#include "core/eval/trajectory_metrics.hpp"
#include "replay_test_util.hpp"
#include "seavio_lcm/status_t.hpp"
#include "tools/lcm_trajectory.hpp"

namespace seavio::tools {
namespace {

TEST(PoseLog, TrajectoryFromLogEqualsPublishedPoses) {
  test::Scratch dir("poses");
  const std::string path = dir.file("out.lcmlog");
  {
    drivers::LcmLogWriter w(path);
    ASSERT_TRUE(w.good()) << w.error();
    test::writePoseLog(w, 40, [](int) { return 20.0; });
    seavio_lcm::status_t s{};
    s.version = seavio_lcm::status_t::VERSION;
    ASSERT_TRUE(w.write("SEAVIO_STATUS", s, 1));
    const uint8_t junk[3] = {1, 2, 3};
    ASSERT_TRUE(w.writeRaw("SOMETHING_ELSE", junk, 3, 2));
  }
  ASSERT_TRUE(isLcmLog(path));
  const DaemonOutputLog log = readDaemonOutputLog(path);
  EXPECT_EQ(log.poses.size(), 40u);
  EXPECT_EQ(log.statuses.size(), 1u);
  EXPECT_EQ(log.stats.events, 42u);
  EXPECT_EQ(log.stats.other_channels.at("SOMETHING_ELSE"), 1u);
  EXPECT_FALSE(log.stats.damaged());

  const std::vector<eval::TimedPose> est = trajectoryFromLog(log);
  ASSERT_EQ(est.size(), 40u);
  std::vector<eval::TimedPose> gt;
  for (int i = 0; i < 40; ++i) {
    const OdometryResult r = test::helixPose(i);
    gt.push_back({r.t_ns, r.T_W_B});
    EXPECT_EQ(est[i].t_ns, r.t_ns);
    EXPECT_LT((est[i].T_W_B.translation() - r.T_W_B.translation()).norm(), 1e-12);
    EXPECT_LT((est[i].T_W_B.linear() - r.T_W_B.linear()).norm(), 1e-9);
  }
  const eval::TrajectoryMetrics m = eval::evaluateTrajectory(gt, est, {});
  EXPECT_EQ(m.associated, 40u);
  EXPECT_LT(m.max_error_m, 1e-9);
  EXPECT_LT(m.ate_rmse_m, 1e-9);
}

TEST(PoseLog, TumFileIsNotTakenForAnLcmLog) {
  test::Scratch dir("tum");
  const std::string path = dir.file("est.tum");
  std::ofstream(path) << "1.0 0 0 0 0 0 0 1\n";
  EXPECT_FALSE(isLcmLog(path));
  EXPECT_FALSE(isLcmLog(dir.file("missing.lcmlog")));
}

TEST(PoseLog, NonLogFileThrowsNamingIt) {
  test::Scratch dir("notlog");
  const std::string path = dir.file("garbage.lcmlog");
  std::ofstream(path) << "this is not an lcm log at all";
  try {
    readDaemonOutputLog(path);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("garbage.lcmlog"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readDaemonOutputLog(dir.file("missing.lcmlog")), std::runtime_error);
}

}  // namespace
}  // namespace seavio::tools
