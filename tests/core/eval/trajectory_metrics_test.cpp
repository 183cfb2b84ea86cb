#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "core/eval/trajectory_metrics.hpp"

namespace seavio::eval {
namespace {

/// Straight line along x at 1 m/s sampled at 10 Hz for `seconds`.
std::vector<TimedPose> line(double seconds, double speed = 1.0, int64_t dt_ns = 100'000'000) {
  std::vector<TimedPose> out;
  for (int64_t t = 0; t <= int64_t(std::llround(seconds * 1e9)); t += dt_ns) {
    TimedPose p;
    p.t_ns = t;
    p.T_W_B.translation() = Eigen::Vector3d(speed * 1e-9 * double(t), 0, 0);
    out.push_back(p);
  }
  return out;
}

TEST(TrajectoryMetrics, PerfectEstimateInAnotherWorldFrameHasZeroError) {
  // GIVEN the truth seen from a world frame rotated 90 deg and shifted.
  const auto gt = line(10.0);
  Eigen::Isometry3d T_other = Eigen::Isometry3d::Identity();
  T_other.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_other.translation() = Eigen::Vector3d(5, -3, 2);
  auto est = gt;
  for (auto& p : est) p.T_W_B = T_other * p.T_W_B;
  const TrajectoryMetrics m = evaluateTrajectory(gt, est);
  EXPECT_EQ(m.associated, 101);
  EXPECT_FALSE(m.incomplete);
  EXPECT_NEAR(m.max_error_m, 0, 1e-9);
  EXPECT_NEAR(m.ate_rmse_m, 0, 1e-9);
  EXPECT_NEAR(m.distance_m, 10.0, 1e-9);
  EXPECT_NEAR(m.coverage, 1.0, 1e-12);
}

TEST(TrajectoryMetrics, GravityTiltIsWhatTheFirstPoseAlignmentHides) {
  // GIVEN an estimate whose world is tilted 2 deg about y (a start levelled on a specific force
  // that held an acceleration), exact otherwise, and a truth turning about z
  auto gt = line(10.0);
  for (std::size_t i = 0; i < gt.size(); ++i)
    gt[i].T_W_B.linear() = Eigen::AngleAxisd(0.05 * double(i), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const double tilt_rad = 2.0 * M_PI / 180.0;
  Eigen::Isometry3d T_tilted = Eigen::Isometry3d::Identity();
  T_tilted.linear() = Eigen::AngleAxisd(tilt_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  auto est = gt;
  for (auto& p : est) p.T_W_B = T_tilted * p.T_W_B;
  const TrajectoryMetrics m = evaluateTrajectory(gt, est);
  // THEN aligned on the first pose it is exact, and against gravity it is 2 deg off throughout
  EXPECT_NEAR(m.max_tilt_error_deg, 0.0, 1e-9);
  EXPECT_NEAR(m.max_error_m, 0.0, 1e-9);
  EXPECT_NEAR(m.mean_gravity_tilt_error_deg, 2.0, 1e-9);
  EXPECT_NEAR(m.max_gravity_tilt_error_deg, 2.0, 1e-9);
  // AND its positions, aligned on the first position and heading only, leave the truth by the
  // chord of the 2 deg tilt for each metre flown along the line
  EXPECT_NEAR(m.final_gravity_error_pct, 100.0 * 2.0 * std::sin(0.5 * tilt_rad), 1e-6);
  EXPECT_NEAR(m.mean_gravity_error_pct, 0.5 * m.final_gravity_error_pct, 1e-6);
  // AND an estimate in a world only turned about z (a heading offset) has no gravity tilt
  Eigen::Isometry3d T_turned = Eigen::Isometry3d::Identity();
  T_turned.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (std::size_t i = 0; i < est.size(); ++i) est[i].T_W_B = T_turned * gt[i].T_W_B;
  const TrajectoryMetrics turned = evaluateTrajectory(gt, est);
  EXPECT_NEAR(turned.max_gravity_tilt_error_deg, 0.0, 1e-9);
  EXPECT_NEAR(turned.final_gravity_error_pct, 0.0, 1e-9);
}

TEST(TrajectoryMetrics, TenPercentScaleDriftMatchesHandComputedFigures) {
  // Estimate travels 1.1 m per true metre: error at t is 0.1 * t.
  const auto gt = line(10.0);
  const auto est = line(10.0, 1.1);
  EvalParams p;
  p.rpe_segment_m = 5.0;
  const TrajectoryMetrics m = evaluateTrajectory(gt, est, p);
  ASSERT_EQ(m.associated, 101);
  EXPECT_NEAR(m.mean_error_m, 0.5, 1e-9);
  EXPECT_NEAR(m.max_error_m, 1.0, 1e-9);
  EXPECT_NEAR(m.final_error_m, 1.0, 1e-9);
  // Population std of 0.1 * {0, 0.1, ..., 10}: 0.1 * sqrt(8.5).
  EXPECT_NEAR(m.std_error_m, 0.1 * std::sqrt(8.5), 1e-9);
  EXPECT_NEAR(m.mean_error_pct, 5.0, 1e-7);
  EXPECT_NEAR(m.final_error_pct, 10.0, 1e-7);
  // Umeyama can only shift a line onto a longer line: the residual is the centred error.
  EXPECT_NEAR(m.ate_rmse_m, 0.1 * std::sqrt(8.5), 1e-7);
  EXPECT_GT(m.rpe_segments, 40);
  EXPECT_NEAR(m.rpe_trans_pct, 10.0, 1e-6);
  EXPECT_NEAR(m.rpe_rot_deg_per_m, 0.0, 1e-9);
  ASSERT_EQ(m.error_m.size(), 101u);
  EXPECT_NEAR(m.distance_along_m[50], 5.0, 1e-9);
  EXPECT_NEAR(m.error_m[50], 0.5, 1e-9);
}

TEST(TrajectoryMetrics, RotationDriftGivesDegreesPerMetre) {
  // Heading error grows 0.01 rad per metre travelled; positions are exact.
  const auto gt = line(20.0);
  auto est = gt;
  for (auto& p : est)
    p.T_W_B.linear() = Eigen::AngleAxisd(0.01 * p.T_W_B.translation().x(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const TrajectoryMetrics m = evaluateTrajectory(gt, est);
  EXPECT_NEAR(m.max_error_m, 0.0, 1e-9);
  EXPECT_GT(m.rpe_segments, 0);
  EXPECT_NEAR(m.rpe_rot_deg_per_m, 0.01 * 180.0 / M_PI, 1e-6);
}

TEST(TrajectoryMetrics, SplitsTheErrorIntoHorizontalVerticalAndHeading) {
  // GIVEN an estimate that sinks 2 cm per metre (a pitch drift), whose heading turns 0.01 rad
  // per metre and whose roll drifts 0.02 rad per metre, over 10 m along x.
  const auto gt = line(10.0);
  auto est = gt;
  for (auto& p : est) {
    const double x = p.T_W_B.translation().x();
    p.T_W_B.translation().z() = -0.02 * x;
    p.T_W_B.linear() = (Eigen::AngleAxisd(0.01 * x, Eigen::Vector3d::UnitZ()) *
                        Eigen::AngleAxisd(0.02 * x, Eigen::Vector3d::UnitX()))
                           .toRotationMatrix();
  }
  const TrajectoryMetrics m = evaluateTrajectory(gt, est);
  ASSERT_EQ(m.heading_error_deg.size(), 101u);
  // THEN the error is all vertical: 0.02 x averaged over x = 0..10.
  EXPECT_NEAR(m.mean_vertical_error_m, 0.1, 1e-9);
  EXPECT_NEAR(m.mean_horizontal_error_m, 0.0, 1e-9);
  EXPECT_NEAR(m.mean_error_m, 0.1, 1e-9);
  // AND the heading error is the turn about z alone, signed, the roll drift left out.
  EXPECT_NEAR(m.heading_error_deg[100], 0.1 * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR(m.max_heading_error_deg, 0.1 * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR(m.mean_heading_error_deg, 0.05 * 180.0 / M_PI, 1e-9);
  // AND the tilt error is the roll drift alone, the heading turn left out.
  ASSERT_EQ(m.tilt_error_deg.size(), 101u);
  EXPECT_NEAR(m.tilt_error_deg[100], 0.2 * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR(m.max_tilt_error_deg, 0.2 * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR(m.mean_tilt_error_deg, 0.1 * 180.0 / M_PI, 1e-9);

  // GIVEN a cross-track drift of 3 cm per metre, heading exact, seen from a world frame
  // turned by 0.2 rad about z.
  Eigen::Isometry3d T_other = Eigen::Isometry3d::Identity();
  T_other.linear() = Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  auto side = gt;
  for (auto& p : side) {
    p.T_W_B.translation().y() = -0.03 * p.T_W_B.translation().x();
    p.T_W_B = T_other * p.T_W_B;
  }
  const TrajectoryMetrics h = evaluateTrajectory(gt, side);
  // THEN the first-pose alignment takes the frame's turn away and the error is horizontal.
  EXPECT_NEAR(h.mean_horizontal_error_m, 0.15, 1e-9);
  EXPECT_NEAR(h.mean_vertical_error_m, 0.0, 1e-9);
  EXPECT_NEAR(h.max_heading_error_deg, 0.0, 1e-9);
  EXPECT_NEAR(h.max_tilt_error_deg, 0.0, 1e-9);
}

TEST(TrajectoryMetrics, HeadingStepRmsIsThePerFrameHeadingNoiseOnStraightStretchesOnly) {
  // GIVEN 10 s straight at 10 Hz, then 10 s turning at 0.2 rad/s; the estimate's heading
  // error jumps by +-a from frame to frame on the straight and by +-5a in the turn.
  constexpr double a = 2e-4;
  std::vector<TimedPose> gt, est;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  double yaw = 0;
  for (int i = 0; i < 200; ++i) {
    TimedPose g;
    g.t_ns = int64_t(i) * 100'000'000;
    if (i >= 100) yaw += 0.02;
    p += 0.1 * Eigen::Vector3d(std::cos(yaw), std::sin(yaw), 0);
    g.T_W_B.translation() = p;
    g.T_W_B.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    gt.push_back(g);
    TimedPose e = g;
    const double error = i % 2 == 0 ? 0.0 : (i < 100 ? a : 5 * a);
    e.T_W_B.linear() = Eigen::AngleAxisd(error, Eigen::Vector3d::UnitZ()).toRotationMatrix() * g.T_W_B.linear();
    est.push_back(e);
  }
  const TrajectoryMetrics m = evaluateTrajectory(gt, est);
  // THEN the 99 straight steps count, the turn's do not (0.2 rad/s > 0.01), and the rms is a.
  EXPECT_EQ(m.heading_steps, 99);
  EXPECT_NEAR(m.heading_step_rms_rad, a, 1e-9);
  // A constant heading error has no steps.
  for (auto& e : est) e.T_W_B.linear() = Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (std::size_t i = 0; i < est.size(); ++i) est[i].T_W_B.linear() = est[i].T_W_B.linear() * gt[i].T_W_B.linear();
  EXPECT_NEAR(evaluateTrajectory(gt, est).heading_step_rms_rad, 0, 1e-9);
}

TEST(TrajectoryMetrics, HeadingStepMedianAndP90TellWideStepsFromAFewOutliers) {
  // GIVEN 101 poses straight at 10 Hz; the heading error's steps are 1a, 2a, ..., 10a, ten
  // of each, alternating in sign.
  constexpr double a = 1e-4;
  std::vector<TimedPose> gt, est;
  double heading_error = 0;
  for (int i = 0; i <= 100; ++i) {
    TimedPose g;
    g.t_ns = int64_t(i) * 100'000'000;
    g.T_W_B.translation() = Eigen::Vector3d(0.1 * i, 0, 0);
    gt.push_back(g);
    if (i > 0) heading_error += (i % 2 ? 1 : -1) * a * ((i - 1) % 10 + 1);
    TimedPose e = g;
    e.T_W_B.linear() = Eigen::AngleAxisd(heading_error, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    est.push_back(e);
  }
  // THEN the 100 steps' sizes have the nearest-rank median 6a and 90th percentile 10a
  const TrajectoryMetrics m = evaluateTrajectory(gt, est);
  ASSERT_EQ(m.heading_steps, 100);
  EXPECT_NEAR(m.heading_step_median_rad, 6 * a, 1e-9);
  EXPECT_NEAR(m.heading_step_p90_rad, 10 * a, 1e-9);
  // AND one pose 100a off (two steps of ~100a) more than doubles the rms, the median moves a rank
  est[50].T_W_B.linear() = Eigen::AngleAxisd(100 * a, Eigen::Vector3d::UnitZ()).toRotationMatrix() * est[50].T_W_B.linear();
  const TrajectoryMetrics o = evaluateTrajectory(gt, est);
  EXPECT_GT(o.heading_step_rms_rad, 2 * m.heading_step_rms_rad);
  EXPECT_NEAR(o.heading_step_median_rad, m.heading_step_median_rad, 1.01 * a);
}

TEST(TrajectoryMetrics, InterpolatesGroundTruthBetweenSamples) {
  // Estimate at 10 Hz, offset by 50 ms: halfway between ground-truth samples.
  const auto gt = line(5.0);
  std::vector<TimedPose> est;
  for (int64_t t = 50'000'000; t < 5'000'000'000; t += 100'000'000) {
    TimedPose p;
    p.t_ns = t;
    p.T_W_B.translation() = Eigen::Vector3d(1e-9 * double(t), 0, 0);
    p.T_W_B.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
    est.push_back(p);
  }
  auto gt_rot = gt;
  for (auto& g : gt_rot) g.T_W_B.linear() = est[0].T_W_B.linear();
  const TrajectoryMetrics m = evaluateTrajectory(gt_rot, est);
  EXPECT_EQ(m.associated, int(est.size()));
  EXPECT_NEAR(m.max_error_m, 0.0, 1e-9);
  const Eigen::Isometry3d mid = interpolate(gt[1].T_W_B, gt[2].T_W_B, 0.25);
  EXPECT_NEAR(mid.translation().x(), 0.125, 1e-12);
}

TEST(TrajectoryMetrics, EstimatesFarFromGroundTruthAreNotAssociated) {
  const auto gt = line(1.0);  // 0 .. 1 s
  std::vector<TimedPose> est = line(1.0);
  TimedPose late;
  late.t_ns = 1'004'000'000;  // 4 ms after the last truth sample: nearest, within max_dt
  est.push_back(late);
  late.t_ns = 1'006'000'000;  // 6 ms: beyond the 5 ms default
  est.push_back(late);
  const TrajectoryMetrics m = evaluateTrajectory(gt, est);
  EXPECT_EQ(m.associated, 12);
  EXPECT_EQ(m.est_poses, 13);
}

TEST(TrajectoryMetrics, ShortEstimateIsFlaggedIncomplete) {
  const auto gt = line(10.0);
  std::vector<TimedPose> half(gt.begin(), gt.begin() + 50);
  TrajectoryMetrics m = evaluateTrajectory(gt, half);
  EXPECT_TRUE(m.incomplete);
  EXPECT_NEAR(m.coverage, 51.0 / 101.0, 0.02);

  // A 1 Hz estimate of 10 Hz truth covers every frame: complete.
  std::vector<TimedPose> sparse;
  for (std::size_t i = 0; i < gt.size(); i += 10) sparse.push_back(gt[i]);
  m = evaluateTrajectory(gt, sparse);
  EXPECT_FALSE(m.incomplete);
  EXPECT_EQ(m.associated, 11);

  // A gap of 3 s in the middle is seen even though start and end are there.
  std::vector<TimedPose> gap;
  for (const auto& g : gt)
    if (g.t_ns < 3'000'000'000 || g.t_ns > 6'000'000'000) gap.push_back(g);
  m = evaluateTrajectory(gt, gap);
  EXPECT_TRUE(m.incomplete);

  m = evaluateTrajectory(gt, {});
  EXPECT_TRUE(m.incomplete);
  EXPECT_EQ(m.associated, 0);
}

TEST(TrajectoryMetrics, CoverageCountsOnlyTheCameraSpan) {
  // GIVEN truth over 0 .. 10 s and a complete estimate over the images' 2 .. 8 s, as on a
  // real recording whose truth starts before the first image and ends after the last.
  const auto gt = line(10.0);
  std::vector<TimedPose> est;
  for (const auto& g : gt)
    if (g.t_ns >= 2'000'000'000 && g.t_ns <= 8'000'000'000) est.push_back(g);
  // Against the whole truth it covers 61 of 101 frames: incomplete.
  TrajectoryMetrics m = evaluateTrajectory(gt, est);
  EXPECT_TRUE(m.incomplete);
  EXPECT_NEAR(m.coverage, 61.0 / 101.0, 0.02);

  // Over the camera span it is complete.
  EvalParams p;
  p.coverage_first_ns = 2'000'000'000;
  p.coverage_last_ns = 8'000'000'000;
  m = evaluateTrajectory(gt, est, p);
  EXPECT_FALSE(m.incomplete);
  EXPECT_NEAR(m.coverage, 1.0, 1e-12);

  // An estimate that stops half way through the camera span is still incomplete.
  std::vector<TimedPose> half;
  for (const auto& e : est)
    if (e.t_ns <= 5'000'000'000) half.push_back(e);
  m = evaluateTrajectory(gt, half, p);
  EXPECT_TRUE(m.incomplete);
  EXPECT_NEAR(m.coverage, 32.0 / 61.0, 0.02);
}

TEST(TrajectoryMetrics, UmeyamaRecoversRigidTransform) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-5, 5);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(1.2, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(1, -2, 0.5);
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 20; ++i) {
    src.emplace_back(u(rng), u(rng), u(rng));
    dst.push_back(T * src.back());
  }
  const Eigen::Isometry3d A = alignUmeyama(src, dst);
  EXPECT_LT((A.matrix() - T.matrix()).norm(), 1e-9);
}

}  // namespace
}  // namespace seavio::eval
