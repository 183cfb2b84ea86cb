// KITTI raw 2011_09_26_drive_0001 (EuRoC layout; its README gives source, licence and what is
// approximate): a car's forward-looking stereo pair, a 10 Hz IMU with one sample per frame,
// 1242x375 rectified images with zero distortion, RTK/INS ground truth that starts before the
// first image and ends after the last. Data no parameter was chosen on: the bounds below are
// its measured figures with a margin, so a change that breaks real data fails here.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/eval/trajectory_metrics.hpp"
#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/dataset.hpp"
#include "tools/sequence_runner.hpp"

namespace seavio {
namespace kitti_raw_test {
namespace {

namespace fs = std::filesystem;

constexpr const char* kSequence = "kitti_raw_2011_09_26_drive_0001";

std::string sequenceDir() {
  const char* env = std::getenv("SEAVIO_REAL_DATA");
  return (fs::path(env && *env ? env : SEAVIO_REAL_DATA_DIR) / kSequence).string();
}

/// Loads the sequence, failing (not skipping) the test when it is not there.
drivers::Dataset load() {
  const std::string dir = sequenceDir();
  if (!fs::is_directory(dir)) {
    ADD_FAILURE() << dir << ": the real sequence is missing. Copy " << kSequence
                  << " there, or point SEAVIO_REAL_DATA (run time) or -DSEAVIO_REAL_DATA_DIR (configure time) "
                     "at the folder that holds it.";
    return {};
  }
  return drivers::loadDataset(dir);
}

eval::TrajectoryMetrics evaluate(const drivers::Dataset& ds, const std::vector<eval::TimedPose>& est) {
  std::vector<eval::TimedPose> gt;
  for (const auto& g : ds.ground_truth) gt.push_back({g.t_ns, g.T_W_B});
  eval::EvalParams p;
  p.coverage_first_ns = ds.frames.front().t_ns;
  p.coverage_last_ns = ds.frames.back().t_ns;
  return eval::evaluateTrajectory(gt, est, p);
}

TEST(KittiRaw, ReadersTakeWhatRealDataHas) {
  const drivers::Dataset ds = load();
  ASSERT_FALSE(ds.frames.empty());
  EXPECT_EQ(ds.frames.size(), 107u);
  EXPECT_EQ(ds.calibration.cam0.width, 1242);
  EXPECT_EQ(ds.calibration.cam0.height, 375);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(ds.calibration.cam0.distortion[i], 0.0);
  // One IMU sample per frame, the first before the first image.
  ASSERT_TRUE(ds.has_imu);
  EXPECT_DOUBLE_EQ(ds.imu_noise.rate_hz, 10.0);
  EXPECT_LE(ds.imu.front().t_ns, ds.frames.front().t_ns);
  EXPECT_GE(ds.imu.back().t_ns, ds.frames.back().t_ns);
  // Ground truth from before the first image to after the last.
  ASSERT_FALSE(ds.ground_truth.empty());
  EXPECT_LT(ds.ground_truth.front().t_ns, ds.frames.front().t_ns);
  EXPECT_GT(ds.ground_truth.back().t_ns, ds.frames.back().t_ns);
  const StereoFrame f = drivers::loadFrame(ds, 0);
  EXPECT_EQ(f.left.cols, 1242);
  EXPECT_EQ(f.right.rows, 375);
}

// The whole sequence, local mode, shipped defaults: complete over the camera span, and within
// the measured figures' bounds.
// The shipped default is the underwater rig's profile: on a car most frames are refused. What
// must hold on any rig: the estimate is evaluated over the camera span (the ground truth runs
// past the images), and every frame that coasts names the check that refused it. The car's
// accuracy with its own profile is tests/tools/kitti.
TEST(KittiRaw, WithTheUnderwaterProfileEveryCoastingFrameNamesItsRefusal) {
  const drivers::Dataset ds = load();
  ASSERT_FALSE(ds.frames.empty());
  const tools::SequenceRun run = tools::runSequence(ds, config::loadOdometryParamsFile(""));
  ASSERT_EQ(run.trajectory.size(), ds.frames.size());
  int coasting = 0, unexplained = 0;
  for (std::size_t i = 1; i < run.results.size(); ++i) {
    const auto& r = run.results[i];
    if (r.source != PoseSource::kImuOnly) continue;
    ++coasting;
    unexplained += r.refusal.check == Refusal::kNone;
  }
  const eval::TrajectoryMetrics m = evaluate(ds, run.trajectory);
  EXPECT_FALSE(m.incomplete) << "coverage " << m.coverage;
  EXPECT_NEAR(m.distance_m, 107.0, 3.0);
  EXPECT_GT(coasting, 0) << "a car at 5-13 m/s is outside the underwater profile's speed bound";
  EXPECT_EQ(unexplained, 0) << "of " << coasting << " coasting frames";
}

}  // namespace
}  // namespace kitti_raw_test
}  // namespace seavio
