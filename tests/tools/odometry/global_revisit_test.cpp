// The global variant bounds the drift when the survey comes back over earlier
// ground. Two overlapping legs (lane spacing below the image footprint) on a tuning seed.
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/eval/trajectory_metrics.hpp"
#include "tests/tools/odometry/pruning_fixture.hpp"
#include "tools/bench_report.hpp"
#include "tools/sequence_runner.hpp"

namespace seavio {
namespace {

namespace fs = std::filesystem;

/// Out 6 m, a tight U-turn, back 6 m over the first leg (lanes 1.5 m apart, footprint
/// ~3.5 x 4.6 m), at 4 Hz.
simulate::SimConfig overlappingLegs(uint32_t seed) {
  simulate::SimConfig c = testing_support::cruiseConfig(seed, 76);
  c.frame_rate_hz = 4.0;
  c.trajectory.legs = 2;
  c.trajectory.leg_length_m = 6.0;
  c.trajectory.leg_spacing_m = 1.5;
  // A turn tight enough for that spacing (the preset's rate limits would widen it to ~7 m).
  c.trajectory.max_yaw_rate_rad_s = 1.5;
  c.trajectory.max_yaw_accel_rad_s2 = 3.0;
  return c;
}

struct ModeRun {
  eval::TrajectoryMetrics metrics;
  tools::SequenceRun sequence;
};

ModeRun run(const drivers::Dataset& ds, odometry::Mode mode) {
  odometry::OdometryParams p;
  p.mode = mode;
  p.min_revisit_age_s = 5.0;  // the survey is 19 s long
  ModeRun out;
  out.sequence = tools::runSequence(ds, p);
  std::vector<eval::TimedPose> gt;
  for (const auto& g : ds.ground_truth) gt.push_back({g.t_ns, g.T_W_B});
  out.metrics = eval::evaluateTrajectory(gt, out.sequence.trajectory);
  return out;
}

TEST(GlobalMap, ReobservesTheFirstLegWhenComingBackOverIt) {
  // GIVEN a tuning seed whose second leg runs back over the first
  const fs::path dir = fs::temp_directory_path() / "seavio_global_revisit_11";
  simulate::writeSequence(overlappingLegs(11), dir.string(), true);
  const drivers::Dataset ds = drivers::loadEuroc(dir.string());
  // WHEN local and global run over it
  const ModeRun local = run(ds, odometry::Mode::kLocal);
  const ModeRun global = run(ds, odometry::Mode::kGlobal);
  std::cout << "[ revisit  ] local mean " << local.metrics.mean_error_m << " m final " << local.metrics.final_error_m
            << " m; global mean " << global.metrics.mean_error_m << " m final " << global.metrics.final_error_m
            << " m over " << global.metrics.distance_m << " m, " << global.sequence.revisit_corrections
            << " revisit corrections, map " << global.sequence.map_bytes << " bytes\n";
  // THEN the global variant re-observes the first leg from the opposite heading and stays at
  // the local variant's centimetre level. Over 18 m the local drift (~5 mm) is below the
  // re-observation's own noise, so global cannot win here; it wins where drift has grown:
  // `seavio bench paper --scale 0.1` (441 m), see docs/architecture.md. The final error is one
  // pose and follows the last revisit correction: over four draws of the vision noise
  // (odometry.seed 1-4, three ripple harmonics notched) 17 / 19 / 6 / 19 mm against local's
  // 7 mm, so it gets 2 cm; the mean stays within 1 cm (7-8 mm against 4 mm).
  EXPECT_GT(global.sequence.revisit_corrections, 5);
  EXPECT_GT(global.sequence.map_bytes, 0u);
  EXPECT_LT(global.metrics.mean_error_m, local.metrics.mean_error_m + 0.01);
  EXPECT_LT(global.metrics.final_error_m, local.metrics.final_error_m + 0.02);
  EXPECT_FALSE(global.metrics.incomplete);
}

// Global beats local on both datasets, on sequences the code was not tuned on:
// GIVEN the paper's plain and snow surveys at a tenth of their length (300 frames at 1 Hz,
// 442 m, lanes overlapping as in the full survey) and a quarter of the pixels, on seed 19
// (never used for tuning), WHEN `seavio bench paper` runs both variants on both, THEN the
// global variant's mean error is at least a fifth below the local one's on each floor, and
// plain global stays under the goal of 0.03 % of distance. Seeds 19 / 29 / 37:
// global / local 0.64 / 0.67 / 0.57 plain, 0.67 / 0.81 / 0.57 snow. (At 320 x 240 snow's
// error is ~5 x plain's, at the full 640 x 480 1.14 x: the accuracy figures are taken there,
// git history of docs/benchmarks.md.)
TEST(GlobalMap, BeatsLocalOnPlainAndSnowPaperSurveysAtATenth) {
  tools::PaperBenchOptions o;
  o.scale = 0.1;
  o.width_px = 320;
  o.seed = 19;
  o.out_dir = (fs::temp_directory_path() / "seavio_global_vs_local_19").string();
  fs::remove_all(o.out_dir);
  const std::vector<tools::BenchRun> runs = tools::runPaperBench(o);
  auto find = [&](const std::string& variant, const std::string& data) -> const tools::BenchRun& {
    for (const auto& r : runs)
      if (r.variant == variant && r.dataset == data) return r;
    throw std::runtime_error("no " + variant + " " + data + " run");
  };
  for (const std::string data : {"plain", "snow"}) {
    SCOPED_TRACE(data);
    const tools::BenchRun &local = find("local", data), &global = find("global", data);
    std::cout << "[ paper/10 ] " << data << ": local " << local.mean_error_m << " m, global " << global.mean_error_m
              << " m (" << global.mean_error_pct << " %) over " << global.distance_m << " m\n";
    EXPECT_EQ(global.frames, 300);
    EXPECT_LT(global.mean_error_m, 0.8 * local.mean_error_m);
  }
  EXPECT_LT(find("global", "plain").mean_error_pct, 0.03);
  fs::remove_all(o.out_dir);
}

}  // namespace
}  // namespace seavio
