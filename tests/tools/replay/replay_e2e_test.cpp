// GIVEN a 30-frame simulated sequence at 15 fps converted to an LCM log, WHEN the daemon
// library replays it from the log (file:// LCM sources in, LCM file provider out) in
// deterministic mode, THEN every frame is processed, none is dropped, and the poses in the
// daemon's output log equal those of core Odometry run directly on the dataset (`seavio run`).
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "core/odometry/odometry.hpp"
#include "daemon/daemon.hpp"
#include "daemon/odometry_processor.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/lcm/dataset_log.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_sources.hpp"
#include "tests/tools/simulate/sim_test_util.hpp"
#include "tools/lcm_trajectory.hpp"
#include "tools/profile_report.hpp"
#include "tools/simulate/sequence_writer.hpp"

#include "tests/tools/replay/run_directly.hpp"

namespace seavio::tools {
namespace {

using namespace std::chrono_literals;

TEST(ReplayEndToEnd, DaemonFromLcmLogGivesTheSamePosesAsSeavioRun) {
  simulate::test::ScratchDir dir("replay_e2e");
  simulate::SimConfig sim = simulate::test::smallConfig(30);
  sim.frame_rate_hz = 15.0;
  simulate::writeSequence(sim, dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  ASSERT_EQ(ds.frames.size(), 30u);
  const std::string in = dir.str() + "/in.lcmlog", out = dir.str() + "/out.lcmlog";
  ASSERT_TRUE(drivers::writeDatasetLog(ds, in).ok());

  daemon::DaemonConfig cfg;
  cfg.lcm.url = "file://" + out + "?mode=w";
  cfg.drain_to_newest = false;
  cfg.backpressure = true;
  cfg.imu_wait_ms = 10'000;  // wait for the IMU to pass each frame: same batches as `seavio run`
  std::string error;
  auto processor = daemon::OdometryProcessor::create(ds.calibration, ds.imu_noise, {}, &error);
  ASSERT_TRUE(processor) << error;
  // speed=0: the file:// sources hand over the next event when asked: consumer paced, nothing lost.
  const std::string replay_url = "file://" + in + "?speed=0";
  {
    daemon::Daemon d(cfg, std::make_unique<drivers::LcmStereoSource>(replay_url, "SEAVIO_STEREO"),
                     std::make_unique<drivers::LcmImuSource>(replay_url, "SEAVIO_IMU"), std::move(processor));
    ASSERT_TRUE(d.start()) << d.error();
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    while (d.health().poses_published < 30 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(10ms);
    d.stop();
    EXPECT_EQ(d.health().frames_in.load(), 30u);
    EXPECT_EQ(d.framesDroppedInRing(), 0u);
    EXPECT_EQ(d.health().processing_failures.load(), 0u);
  }  // the output log is flushed when the daemon's LCM instance closes

  const DaemonOutputLog log = readDaemonOutputLog(out);
  EXPECT_FALSE(log.stats.damaged());
  ASSERT_EQ(log.poses.size(), 30u);
  const std::vector<OdometryResult> ref = testing_support::runDirectly(ds);
  ASSERT_EQ(ref.size(), 30u);
  for (std::size_t i = 0; i < 30; ++i) {
    const seavio_lcm::pose_t& got = log.poses[i].msg;
    const seavio_lcm::pose_t want = drivers::toPoseMsg(ref[i], got.publish_t_ns);
    EXPECT_EQ(got.t_ns, want.t_ns) << i;
    EXPECT_EQ(got.seq, want.seq) << i;
    EXPECT_EQ(got.flags, want.flags) << i;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(got.position[k], want.position[k]) << i;
    for (int k = 0; k < 4; ++k) EXPECT_EQ(got.quaternion[k], want.quaternion[k]) << i;
    EXPECT_EQ(got.ransac_inliers, want.ransac_inliers) << i;
  }
  // Vision worked on most frames, so the comparison is not between two trivial trajectories.
  int visual = 0;
  for (const LoggedPose& p : log.poses) visual += (p.msg.flags & seavio_lcm::pose_t::FLAG_VISUAL) ? 1 : 0;
  EXPECT_GE(visual, 20);
  EXPECT_GT(log.poses.back().msg.position[0] * log.poses.back().msg.position[0] +
                log.poses.back().msg.position[1] * log.poses.back().msg.position[1],
            0.0);
  // The output log profiles: no frame lost between the log and the poses.
  const ProfileReport r = computeProfile(log);
  EXPECT_EQ(r.frames.size(), 30u);
  EXPECT_EQ(r.seq_gaps, 0u);
}

}  // namespace
}  // namespace seavio::tools
