// Real data (README "Rig profiles"): GIVEN KITTI raw 2011_09_26_drive_0001 (a forward-looking
// car rig, 1242x375, 0.54 m baseline, 107 frames at 10 Hz over 107 m at 4.6-13.2 m/s, depths
// 5-80 m; RTK/INS ground truth) and the car-forward profile, WHEN the odometry runs over it as
// `seavio run --config config/profiles/car-forward.yaml` does, THEN the drift stays within the
// bounds measured on it and is no worse than vision alone's, and the few frames that coast are
// refused by the inertial gate (the 10 Hz INS integrates braking coarsely); AND without the IMU
// stream (the KITTI odometry layout) vision alone tracks every frame. The data is validation: no parameter was
// chosen on it. It lives in data/real (SEAVIO_REAL_DATA_DIR); a missing folder fails the test.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/eval/trajectory_metrics.hpp"
#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/dataset.hpp"
#include "tools/sequence_runner.hpp"

namespace seavio {
namespace {

namespace fs = std::filesystem;

// Bounds: the figures measured on this sequence with a small margin (the run is deterministic;
// the margin covers compiler and library differences). Above the targets (0.8 / 0.4 %,
// vision alone 1.0 %): these hold what is reached, so a change that loses ground fails.
constexpr double kFinalPct = 1.9;          // measured 1.79 %
constexpr double kMeanPct = 1.0;           // measured 0.95 %
constexpr double kVisionOnlyFinalPct = 2.0;  // measured 1.86 % (prediction: constant_velocity)

drivers::Dataset loadKittiRaw() {
  const std::string dir = std::string(SEAVIO_REAL_DATA_DIR) + "/kitti_raw_2011_09_26_drive_0001";
  if (!fs::is_directory(dir)) throw std::runtime_error(dir + ": real data missing (SEAVIO_REAL_DATA_DIR)");
  return drivers::loadEuroc(dir);
}

odometry::OdometryParams carForward() {
  return config::loadOdometryParamsFile(std::string(SEAVIO_SOURCE_DIR) + "/config/profiles/car-forward.yaml");
}

struct Figures {
  int coasting = 0;
  int gated = 0;  ///< coasting frames refused by the inertial gate
  eval::TrajectoryMetrics m;
};

Figures run(const drivers::Dataset& ds, const odometry::OdometryParams& params, const char* what) {
  const tools::SequenceRun r = tools::runSequence(ds, params);
  Figures f;
  for (const OdometryResult& o : r.results) {
    f.coasting += o.source == PoseSource::kImuOnly;
    f.gated += o.source == PoseSource::kImuOnly && o.refusal.check == Refusal::kInertialGate;
  }
  std::vector<eval::TimedPose> gt;
  for (const auto& g : ds.ground_truth) gt.push_back({g.t_ns, g.T_W_B});
  f.m = eval::evaluateTrajectory(gt, r.trajectory);
  std::printf("KITTI raw 0001, %s: %zu frames, %d coasting, mean %.3f %%, final %.3f %% of %.1f m\n", what,
              r.results.size(), f.coasting, f.m.mean_error_pct, f.m.final_error_pct, f.m.distance_m);
  return f;
}

TEST(KittiRaw, CarForwardProfileWithTheImuDriftsNoMoreThanVisionAlone) {
  const drivers::Dataset ds = loadKittiRaw();
  ASSERT_TRUE(ds.has_imu);
  const Figures f = run(ds, carForward(), "car-forward");
  odometry::OdometryParams vision_only = carForward();
  vision_only.prediction = odometry::Prediction::kConstantVelocity;
  const Figures v = run(ds, vision_only, "car-forward, prediction constant_velocity");
  EXPECT_FALSE(f.m.incomplete);
  EXPECT_GT(f.m.distance_m, 100.0);
  EXPECT_LE(f.coasting, 6);  // measured 4 of 107
  EXPECT_EQ(f.gated, f.coasting);
  EXPECT_LE(f.m.final_error_pct, kFinalPct);
  EXPECT_LE(f.m.mean_error_pct, kMeanPct);
  EXPECT_LE(f.m.final_error_pct, v.m.final_error_pct);
  EXPECT_LE(f.m.mean_error_pct, v.m.mean_error_pct);
}

TEST(KittiRaw, VisionAloneWithoutAnImuStreamTracksEveryFrame) {
  drivers::Dataset ds = loadKittiRaw();
  ds.imu.clear();
  ds.has_imu = false;
  const Figures f = run(ds, carForward(), "vision only, no IMU stream");
  EXPECT_FALSE(f.m.incomplete);
  EXPECT_EQ(f.coasting, 0);
  EXPECT_LE(f.m.final_error_pct, kVisionOnlyFinalPct);
}

}  // namespace
}  // namespace seavio
