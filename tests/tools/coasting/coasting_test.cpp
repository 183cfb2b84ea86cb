// Coasting through vision loss: GIVEN a short simulated survey with a blackout and a
// turbidity stretch, WHEN the odometry runs over it through `seavio run`'s frame loop, THEN
// every frame inside a stretch is flagged IMU-only (FLAG_IMU_ONLY on LCM), its position
// covariance grows frame by frame, nothing is NaN, vision takes over again right after, and
// the error the stretch added stays bounded. The figures are printed; the same measurement
// over any rendered dataset (e.g. `seavio simulate short-outage`) is `seavio bench coasting`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <unistd.h>
#include <filesystem>
#include <string>

#include "drivers/lcm/lcm_convert.hpp"
#include "tools/coasting_report.hpp"
#include "tools/sequence_runner.hpp"
#include "tools/simulate/imu_simulator.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio {
namespace {

namespace fs = std::filesystem;

const std::vector<double> kAt = {0.5, 1.0, 1.5, 2.0, 3.0, 5.0};

TEST(Coasting, BlackoutAndTurbidityAreFlaggedWithGrowingCovarianceAndVisionRecovers) {
  // GIVEN 13 s at 10 Hz and 1 m/s: a 2 s blackout at 4 s and a 2 s turbidity stretch at 8.5 s
  simulate::SimConfig c = simulate::presetConfig("short-outage");
  c.seed = 31;
  c.frames = 130;
  c.frame_rate_hz = 10.0;
  c.trajectory.still_s = 0.5;
  c.trajectory.accel_s = 1.0;
  c.trajectory.speed_m_s = 1.0;
  c.vision_loss.stretches = {{simulate::VisionLoss::kBlackout, 4.0, 2.0},
                             {simulate::VisionLoss::kTurbidity, 8.5, 2.0}};
  const fs::path dir = fs::temp_directory_path() / ("seavio_coasting_" + std::to_string(getpid()));
  simulate::writeSequence(c, dir.string(), true);
  const drivers::Dataset ds = drivers::loadEuroc(dir.string());
  const std::vector<tools::LossStretch> stretches = tools::readLossStretches(dir.string());
  ASSERT_EQ(stretches.size(), 2u);

  // WHEN the odometry runs over it
  const tools::SequenceRun run = tools::runSequence(ds, odometry::OdometryParams{});
  ASSERT_EQ(run.results.size(), ds.frames.size());

  for (const tools::LossStretch& s : stretches) {
    SCOPED_TRACE(s.kind);
    const tools::CoastFigures f = tools::coastFigures(ds, run.results, s, kAt, 2.0);
    std::printf("%s\n", tools::formatCoastFigures("test survey (seed 31)", s, f).c_str());
    // THEN every frame inside is flagged (the first may still hold on the previous frame's
    // features at the stretch's edge), on LCM too
    ASSERT_GE(f.frames_in_loss, 19);
    EXPECT_GE(f.flagged_in_loss, f.frames_in_loss - 1);
    EXPECT_TRUE(f.finite);
    // AND the position covariance grows at every coasting frame; the stretch adds at least
    // 1 cm of standard deviation (the covariance accumulates over the run, so a second
    // stretch starts from the first one's)
    EXPECT_TRUE(f.covariance_grows);
    EXPECT_GT(std::sqrt(f.sigma_end_m * f.sigma_end_m - f.sigma_start_m * f.sigma_start_m), 0.01);
    // AND vision is back within half a second of the stretch's end
    EXPECT_GE(f.recovery_s, 0.0);
    EXPECT_LE(f.recovery_s, 0.5);
    // AND the error added by 2 s of dead reckoning (a consumer-grade IMU, bias known from the
    // visual phase) stays a fraction of the distance, and recovery does not add to it
    EXPECT_LT(f.error_end_m, 0.25 * f.distance_m) << "over " << f.distance_m << " m";
    EXPECT_LT(f.error_after_m, f.error_end_m + 0.05);
  }
  for (std::size_t i = 0; i < run.results.size(); ++i) {
    const OdometryResult& r = run.results[i];
    if (r.source != PoseSource::kImuOnly) continue;
    const seavio_lcm::pose_t m = drivers::toPoseMsg(r, r.t_ns);
    EXPECT_TRUE(m.flags & seavio_lcm::pose_t::FLAG_IMU_ONLY) << "frame " << i;
    EXPECT_FALSE(m.flags & seavio_lcm::pose_t::FLAG_VISUAL) << "frame " << i;
  }
  // Outside the stretches vision carries the estimate.
  int imu_only_outside = 0;
  for (const OdometryResult& r : run.results) {
    bool inside = false;
    for (const tools::LossStretch& s : stretches) inside = inside || (r.t_ns >= s.from_ns && r.t_ns < s.to_ns + 500'000'000);
    imu_only_outside += !inside && r.source == PoseSource::kImuOnly;
  }
  EXPECT_EQ(imu_only_outside, 0);
  fs::remove_all(dir);
}

// Consistency of the coasting covariance: GIVEN short surveys on seeds the
// covariance was not tuned on (tuning: seed 5), each with a 5 s blackout, turbidity and
// featureless stretch, WHEN the odometry coasts through them on the inertial filter, THEN the
// position error each stretch adds lies inside three standard deviations of the covariance it
// added (the filter's growth since the last fix), at 0.5, 1, 2 and 5 s, for every kind, AND the
// bound is not uselessly loose (a consistent covariance gives a median 3 sigma / error of about
// 3.4 with sigma = sqrt(trace)), AND vision returns without a jump.
TEST(CoastingConsistency, ErrorInsideThreeSigmaAtHalfOneTwoAndFiveSecondsForEveryKindAndTheBoundIsUseful) {
  const std::vector<double> at = {0.5, 1.0, 2.0, 5.0};
  int inside = 0, checked = 0;
  std::vector<double> looseness;  // 3 sigma / error
  for (const uint32_t seed : {41u, 59u}) {
    simulate::SimConfig c = simulate::presetConfig("short-outage");
    c.seed = seed;
    // The stress model's walks: with the presets' steadier ADIS16448 the errors shrink and the
    // bound is looser, every error still inside.
    c.imu = simulate::imuModel("euroc-kalibr");
    c.frames = 260;
    c.frame_rate_hz = 10.0;
    c.rig.width = 320;  // a quarter of the pixels: the covariance does not depend on them
    c.rig.height = 240;
    c.trajectory.still_s = 0.5;
    c.trajectory.accel_s = 1.0;
    c.trajectory.speed_m_s = 1.0;
    c.vision_loss.stretches = {{simulate::VisionLoss::kBlackout, 4.0, 5.2},
                               {simulate::VisionLoss::kTurbidity, 11.0, 5.2},
                               {simulate::VisionLoss::kFeatureless, 18.0, 5.2}};
    const fs::path dir =
        fs::temp_directory_path() / ("seavio_coasting_nees_" + std::to_string(getpid()) + "_" + std::to_string(seed));
    simulate::writeSequence(c, dir.string(), true);
    const drivers::Dataset ds = drivers::loadEuroc(dir.string());
    const tools::SequenceRun run = tools::runSequence(ds, odometry::OdometryParams{});
    ASSERT_EQ(run.results.size(), ds.frames.size());
    const std::vector<tools::LossStretch> stretches = tools::readLossStretches(dir.string());
    ASSERT_EQ(stretches.size(), 3u);
    for (const tools::LossStretch& s : stretches) {
      SCOPED_TRACE(s.kind + " seed " + std::to_string(seed));
      const tools::CoastFigures f = tools::coastFigures(ds, run.results, s, at, 2.0);
      std::printf("%s\n", tools::formatCoastFigures("consistency (seed " + std::to_string(seed) + ")", s, f).c_str());
      ASSERT_EQ(f.error_m.size(), at.size());
      for (std::size_t i = 0; i < at.size(); ++i) {
        ++checked;
        const bool in = f.error_m[i] <= 3 * f.sigma_added_m[i];
        inside += in;
        EXPECT_TRUE(in) << "at " << at[i] << " s: error " << f.error_m[i] << " m, 3 sigma " << 3 * f.sigma_added_m[i];
        looseness.push_back(3 * f.sigma_added_m[i] / std::max(f.error_m[i], 1e-3));
      }
      // Flagged throughout, vision back within half a second, and no jump when it returns: the
      // first visual pose moves from the last coasting one as the vehicle did (within 5 cm).
      EXPECT_GE(f.flagged_in_loss, f.frames_in_loss - 1);
      EXPECT_TRUE(f.finite);
      EXPECT_GE(f.recovery_s, 0.0);
      EXPECT_LE(f.recovery_s, 0.5);
      EXPECT_GE(f.recovery_jump_m, 0.0);
      EXPECT_LT(f.recovery_jump_m, 0.05);
    }
    fs::remove_all(dir);
  }
  std::sort(looseness.begin(), looseness.end());
  const double median_looseness = looseness[looseness.size() / 2];
  std::printf("coasting consistency: %d of %d errors inside 3 sigma; 3 sigma / error median %.2f (min %.2f max %.2f)\n",
              inside, checked, median_looseness, looseness.front(), looseness.back());
  ASSERT_EQ(checked, 24);
  EXPECT_EQ(inside, checked);
  // Useful, not a formality: within a factor 12 of the error. The filter's covariance carries
  // the tilt and bias uncertainty vision left it, which the stretches' errors fill only partly.
  EXPECT_LE(median_looseness, 12.0);
}

}  // namespace
}  // namespace seavio
