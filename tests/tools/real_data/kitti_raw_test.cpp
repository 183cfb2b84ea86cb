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
// Measured with the shipped defaults (local, the underwater rig's limits on a car): mean 48.5 %,
// final 64.9 % of 106 m, 57 of 107 frames coasting on the IMU. The bounds leave room for
// platform noise, not for a regression; a rig profile that fits the car tightens them.
constexpr double kMeanBoundPct = 55;
constexpr double kFinalBoundPct = 72;
constexpr int kCoastBound = 62;

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
TEST(KittiRaw, LocalOdometryWithDefaultsStaysWithinItsMeasuredFigures) {
  const drivers::Dataset ds = load();
  ASSERT_FALSE(ds.frames.empty());
  const tools::SequenceRun run = tools::runSequence(ds, config::loadOdometryParamsFile(""));
  ASSERT_EQ(run.trajectory.size(), ds.frames.size());
  int coasting = 0;
  for (const auto& r : run.results) coasting += r.source == PoseSource::kImuOnly;
  const eval::TrajectoryMetrics m = evaluate(ds, run.trajectory);
  EXPECT_FALSE(m.incomplete) << "coverage " << m.coverage;
  EXPECT_NEAR(m.distance_m, 107.0, 3.0);
  RecordProperty("mean_error_pct", std::to_string(m.mean_error_pct));
  RecordProperty("final_error_pct", std::to_string(m.final_error_pct));
  RecordProperty("imu_only_frames", coasting);
  EXPECT_LT(m.mean_error_pct, kMeanBoundPct) << "final " << m.final_error_pct << " %, coasting " << coasting;
  EXPECT_LT(m.final_error_pct, kFinalBoundPct) << "mean " << m.mean_error_pct << " %";
  EXPECT_LE(coasting, kCoastBound) << "mean " << m.mean_error_pct << " %, final " << m.final_error_pct << " %";
}

}  // namespace
}  // namespace kitti_raw_test
}  // namespace seavio
