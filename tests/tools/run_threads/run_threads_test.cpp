// `seavio run --threads 2` extracts the right image's features on a persistent worker while
// the left runs on the caller, and shares the four-view RANSAC's hypotheses with that worker.
// Only the order of independent work changes, so every pose, covariance and count must be
// bit-identical to the sequential run.
#include <cstring>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "drivers/dataset/dataset.hpp"
#include "tools/sequence_runner.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio {
namespace {

namespace fs = std::filesystem;

bool sameBits(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return std::memcmp(a.matrix().data(), b.matrix().data(), sizeof(double) * 16) == 0;
}

TEST(RunThreads, ParallelFeaturesAndRansacGiveBitIdenticalTrajectoriesInBothModes) {
  // GIVEN a short simulated survey at a reduced resolution (quick), long enough for the global
  // map to hold several keyframes
  const std::string dir = (fs::temp_directory_path() / "seavio_run_threads").string();
  simulate::SimConfig c = simulate::presetConfig("short-plain");
  c.seed = 41;
  c.frames = 30;
  c.rig.width = 320;
  c.rig.height = 240;
  c.trajectory.still_s = 0.5;
  c.trajectory.accel_s = 1.0;
  simulate::writeSequence(c, dir, true);
  const drivers::Dataset ds = drivers::loadEuroc(dir);
  for (const odometry::Mode mode : {odometry::Mode::kLocal, odometry::Mode::kGlobal}) {
    SCOPED_TRACE(mode == odometry::Mode::kLocal ? "local" : "global");
    odometry::OdometryParams params;
    params.mode = mode;
    // WHEN it runs with left and right features in turn and in parallel
    const tools::SequenceRun one = tools::runSequence(ds, params, 0, {}, 1);
    const tools::SequenceRun two = tools::runSequence(ds, params, 0, {}, 2);
    // THEN every frame's pose, covariance and feature counts are the same, bit for bit
    ASSERT_EQ(one.results.size(), ds.frames.size());
    ASSERT_EQ(two.results.size(), one.results.size());
    int tracked = 0;
    for (std::size_t i = 0; i < one.results.size(); ++i) {
      const OdometryResult& a = one.results[i];
      const OdometryResult& b = two.results[i];
      SCOPED_TRACE("frame " + std::to_string(i));
      EXPECT_EQ(a.t_ns, b.t_ns);
      EXPECT_TRUE(sameBits(a.T_W_B, b.T_W_B));
      EXPECT_EQ(std::memcmp(a.covariance.data(), b.covariance.data(), sizeof(double) * 36), 0);
      EXPECT_EQ(a.quality.features_left, b.quality.features_left);
      EXPECT_EQ(a.quality.features_right, b.quality.features_right);
      EXPECT_EQ(a.quality.stereo_matches, b.quality.stereo_matches);
      EXPECT_EQ(a.quality.ransac_inliers, b.quality.ransac_inliers);
      EXPECT_EQ(a.source, b.source);
      tracked += a.quality.ransac_inliers > 0;
    }
    EXPECT_EQ(one.map_keyframes, two.map_keyframes);
    EXPECT_EQ(one.map_points, two.map_points);
    // The comparison means something only if the visual path ran, and the frontend's right
    // side (rectification, then description: two runs a frame) and the RANSAC on the worker.
    EXPECT_GT(tracked, static_cast<int>(one.results.size()) / 2);
    EXPECT_EQ(one.parallel_runs, 0u);
    EXPECT_GE(two.parallel_runs, 2 * two.results.size() + static_cast<std::size_t>(tracked));
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace seavio
