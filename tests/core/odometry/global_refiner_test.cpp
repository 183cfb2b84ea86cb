// The global step as its own unit (the global ICP on its own thread): GlobalRefiner
// in isolation, and Odometry's deferred mode against the inline one on a synthetic survey
// that comes back over its own ground.
#include "core/odometry/global_refiner.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/imu/imu_integrator.hpp"
#include "core/odometry/odometry.hpp"
#include "tests/core/odometry/downward_rig.hpp"
#include "tests/core/odometry/floor_frame.hpp"

namespace seavio::odometry {
namespace global_refiner_test {
namespace {

using test::downwardRig;

/// Out and back along x: 0 -> 4 m -> 0 over `kPeriod`, so the second half re-visits ground
/// first seen several seconds earlier.
constexpr double kAmp = 2.0, kPeriod = 12.0;  // [m], [s]
Eigen::Isometry3d bodyPose(double t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(kAmp * (1 - std::cos(2 * std::numbers::pi * t / kPeriod)), 0, 0);
  return T;
}
Eigen::Vector3d bodyAccel(double t) {
  const double w = 2 * std::numbers::pi / kPeriod;
  return Eigen::Vector3d(kAmp * w * w * std::cos(w * t), 0, 0);
}

/// Seafloor 4 m below with a random unit descriptor per point; frames and IMU made from it.
struct Survey {
  camera::RectifiedRig rig;
  std::vector<Eigen::Vector3d> world;
  cv::Mat world_desc;
  std::mt19937 rng{7};
  int64_t imu_t = -1'000'000'000;  // IMU from 1 s before the first frame (still start)

  explicit Survey(const camera::RectifiedRig& r) : rig(r) {
    std::uniform_real_distribution<double> ux(-3.0, 8.0), uy(-3.0, 3.0), uz(-0.3, 0.3);
    std::normal_distribution<float> gauss(0.f, 1.f);
    const int n = 1500;
    world.resize(n);
    world_desc.create(n, 64, CV_32F);
    for (int i = 0; i < n; ++i) {
      world[i] = Eigen::Vector3d(ux(rng), uy(rng), -4.0 + uz(rng));  // relief, so ICP is constrained
      for (int d = 0; d < 64; ++d) world_desc.at<float>(i, d) = gauss(rng);
      cv::normalize(world_desc.row(i), world_desc.row(i));
    }
  }

  std::vector<ImuSample> imuUntil(int64_t t_ns) {
    std::vector<ImuSample> out;
    for (; imu_t <= t_ns + 5'000'000; imu_t += 5'000'000) {
      const double ti = std::max(0.0, 1e-9 * static_cast<double>(imu_t));
      ImuSample s;
      s.t_ns = imu_t;
      s.gyro_rad_s = Eigen::Vector3d::Zero();
      s.accel_m_s2 = (imu_t < 0 ? Eigen::Vector3d::Zero() : bodyAccel(ti)) - imu::gravityW();
      out.push_back(s);
    }
    return out;
  }

  FrameFeatures frame(uint64_t seq, double t, const Eigen::Isometry3d& T_W_B, double pixel_sigma) {
    std::normal_distribution<double> pix(0.0, pixel_sigma);
    return test::floorFrame(rig, world, world_desc, T_W_B, seq, static_cast<int64_t>(std::llround(t * 1e9)), pix, rng);
  }
};

camera::StereoRectifier makeRectifier() {
  std::string error;
  auto rectifier = camera::StereoRectifier::create(downwardRig(), &error);
  EXPECT_TRUE(rectifier.has_value()) << error;
  return std::move(*rectifier);
}

OdometryParams globalParams() {
  OdometryParams p;
  p.mode = Mode::kGlobal;
  p.min_revisit_age_s = 6.0;  // only the way back re-visits
  return p;
}

GlobalRequest requestAt(uint64_t id, double t, const Eigen::Isometry3d& T_W_R0, const FrameFeatures& f) {
  GlobalRequest q;
  q.frame_id = id;
  q.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
  q.T_W_R0 = T_W_R0;
  q.pose_covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e-4;
  for (const auto& sp : f.stereo.points) q.points_R0.push_back(sp.p_R0);
  return q;  // no descriptors: ICP only, no re-observation
}

TEST(GlobalRefiner, FirstFrameBecomesAKeyframeAndNothingIsCorrectedWithoutOldGround) {
  // GIVEN an empty refiner
  camera::StereoRectifier rect = makeRectifier();
  Survey survey(rect.rig());
  GlobalRefiner refiner(rect.rig(), globalRefinerParams(globalParams()));
  std::mt19937 rng(1);
  const Eigen::Isometry3d T_W_R0 = bodyPose(0) * rect.rig().T_B_R0;
  GlobalRequest q = requestAt(0, 0.0, T_W_R0, survey.frame(0, 0.0, bodyPose(0), 0.0));
  q.first_frame = true;
  // WHEN the first frame and then a frame 1 s later nearby are refined
  const GlobalCorrection c0 = refiner.refine(q, rng);
  GlobalRequest q1 = requestAt(1, 1.0, T_W_R0, survey.frame(1, 1.0, bodyPose(0), 0.0));
  const GlobalCorrection c1 = refiner.refine(q1, rng);
  // THEN the first is stored, neither is moved: the map holds nothing old enough
  EXPECT_TRUE(c0.keyframe_inserted);
  EXPECT_EQ(refiner.frameMap().size(), 1u);
  for (const GlobalCorrection* c : {&c0, &c1}) {
    EXPECT_FALSE(c->changed());
    EXPECT_FALSE(c->icp_ran);
    EXPECT_EQ(c->rejection, GlobalRejection::kNoRevisit);
    EXPECT_TRUE(c->correction_W.isApprox(Eigen::Isometry3d::Identity(), 1e-12));
  }
  EXPECT_EQ(c1.frame_id, 1u);
}

TEST(GlobalRefiner, IcpPullsADriftedFrameBackWithinTheGateAndRefusesLargerJumps) {
  // GIVEN a keyframe of the floor stored 40 s ago at the true pose
  camera::StereoRectifier rect = makeRectifier();
  const camera::RectifiedRig rig = rect.rig();
  Survey survey(rig);
  GlobalRefiner refiner(rig, globalRefinerParams(globalParams()));
  std::mt19937 rng(1);
  const Eigen::Isometry3d T_W_B = bodyPose(0);
  const Eigen::Isometry3d T_W_R0 = T_W_B * rig.T_B_R0;
  GlobalRequest first = requestAt(0, 0.0, T_W_R0, survey.frame(0, 0.0, T_W_B, 0.0));
  first.first_frame = true;
  (void)refiner.refine(first, rng);

  // WHEN the same ground is seen again with the odometry 2 cm off in x and y
  Eigen::Isometry3d drifted = T_W_R0;
  drifted.translation() += Eigen::Vector3d(0.015, -0.013, 0.0);
  const GlobalCorrection small = refiner.correct({}, requestAt(1, 40.0, drifted, survey.frame(1, 40.0, T_W_B, 0.0)).points_R0,
                                                 1, static_cast<int64_t>(40e9), drifted,
                                                 Eigen::Matrix<double, 6, 6>::Identity() * 1e-4, rng);
  // THEN ICP accepts and brings it back to within a few mm of the truth
  ASSERT_TRUE(small.icp_ran);
  EXPECT_TRUE(small.icp_accepted) << toString(small.rejection);
  EXPECT_GT(small.model_points, 100);
  EXPECT_LT((small.T_W_R0.translation() - T_W_R0.translation()).norm(), 0.005);

  // WHEN it is 20 cm off: further than the odometry could have drifted
  Eigen::Isometry3d far = T_W_R0;
  far.translation() += Eigen::Vector3d(0.2, 0.0, 0.0);
  GlobalRequest q = requestAt(2, 40.0, far, survey.frame(2, 40.0, T_W_B, 0.0));
  const GlobalCorrection large = refiner.refine(q, rng);
  // THEN the frame is left where the odometry put it, and why is said
  EXPECT_FALSE(large.icp_accepted);
  EXPECT_NE(large.rejection, GlobalRejection::kNone);
  EXPECT_TRUE(large.correction_W.isApprox(Eigen::Isometry3d::Identity(), 1e-9));
}

TEST(GlobalRefiner, WithTheTiltKeptTheMapMovesPositionAndHeadingAndLeavesRollAndPitchToTheChain) {
  // GIVEN a keyframe of the floor stored 40 s ago at the true pose, and the same ground seen
  // again with the odometry 1.5 cm off, turned 3 mrad in heading and pitched 3 mrad
  camera::StereoRectifier rect = makeRectifier();
  const camera::RectifiedRig rig = rect.rig();
  Survey survey(rig);
  const Eigen::Isometry3d T_W_B = bodyPose(0);
  const Eigen::Isometry3d T_W_R0 = T_W_B * rig.T_B_R0;
  Eigen::Isometry3d drifted = T_W_R0;
  drifted.translation() += Eigen::Vector3d(0.012, -0.009, 0.0);
  drifted.linear() = (Eigen::AngleAxisd(0.003, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.003, Eigen::Vector3d::UnitY()))
                         .toRotationMatrix() * T_W_R0.linear();
  const auto correctWith = [&](bool keep_tilt) {
    OdometryParams p = globalParams();
    p.map_keeps_tilt = keep_tilt;
    GlobalRefiner refiner(rig, globalRefinerParams(p));
    std::mt19937 rng(1);
    GlobalRequest first = requestAt(0, 0.0, T_W_R0, survey.frame(0, 0.0, T_W_B, 0.0));
    first.first_frame = true;
    (void)refiner.refine(first, rng);
    return refiner.correct({}, requestAt(1, 40.0, drifted, survey.frame(1, 40.0, T_W_B, 0.0)).points_R0, 1,
                           static_cast<int64_t>(40e9), drifted, Eigen::Matrix<double, 6, 6>::Identity() * 1e-4, rng);
  };
  const auto heading = [](const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); };
  const auto tiltBetween = [](const Eigen::Matrix3d& Ra, const Eigen::Matrix3d& Rb) {
    return std::acos(std::clamp((Ra.transpose() * Eigen::Vector3d::UnitZ()).dot(Rb.transpose() * Eigen::Vector3d::UnitZ()), -1.0, 1.0));
  };
  // WHEN ICP corrects it with the tilt kept, and with the full rotation
  const GlobalCorrection kept = correctWith(true), full = correctWith(false);
  ASSERT_TRUE(kept.icp_accepted) << toString(kept.rejection);
  ASSERT_TRUE(full.icp_accepted) << toString(full.rejection);
  // THEN both bring position and heading back to the truth
  for (const GlobalCorrection* c : {&kept, &full}) {
    EXPECT_LT((c->T_W_R0.translation() - T_W_R0.translation()).norm(), 0.005);
    EXPECT_LT(std::abs(heading(c->T_W_R0.linear()) - heading(T_W_R0.linear())), 5e-4);
  }
  // AND with the tilt kept the camera's vertical is the odometry's (3 mrad off), where the
  // full correction levels it
  EXPECT_LT(tiltBetween(kept.T_W_R0.linear(), drifted.linear()), 1e-9);
  EXPECT_NEAR(tiltBetween(kept.T_W_R0.linear(), T_W_R0.linear()), 0.003, 2e-4);
  EXPECT_LT(tiltBetween(full.T_W_R0.linear(), T_W_R0.linear()), 1e-3);
}

/// A straight old leg along x over a long random floor (as in the revisit tests): the body
/// at metre `x` of it and the frame seen there (frame `id` at `id` seconds).
struct OldLeg {
  camera::StereoRectifier rect = makeRectifier();
  camera::RectifiedRig rig = rect.rig();
  std::mt19937 rng{5};
  test::SyntheticFloor floor = test::randomFloor(rng, 6000, -3.0, 40.0, 3.0, -4.0);
  std::normal_distribution<double> pix{0.0, 0.1};

  static Eigen::Isometry3d bodyAt(double x) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(x, 0, 0);
    return T;
  }
  FrameFeatures frameAt(double x, uint64_t id, std::mt19937& noise) {
    return test::floorFrame(rig, floor.points_W, floor.descriptors, bodyAt(x), id,
                            static_cast<int64_t>(id) * 1'000'000'000, pix, noise);
  }
};

/// A leg along x over a long floor, one frame per metre, stored as keyframes at the true
/// poses; then a frame over metre `true_x` of it whose odometry says `estimated_x`, with a
/// position sigma of `sigma_m` per axis, as after kilometres of drift.
GlobalCorrection revisitAfterLargeDrift(int disc_candidates, double true_x, double estimated_x, double sigma_m) {
  OldLeg leg;
  const camera::RectifiedRig& rig = leg.rig;
  std::mt19937& rng = leg.rng;
  OdometryParams p = globalParams();
  p.revisit_disc_candidates = disc_candidates;
  GlobalRefiner refiner(rig, globalRefinerParams(p));
  const auto bodyAt = OldLeg::bodyAt;
  for (int i = 0; i <= 36; ++i) {
    const FrameFeatures f = leg.frameAt(i, static_cast<uint64_t>(i), rng);
    std::vector<Eigen::Vector3f> cloud;
    for (const auto& sp : f.stereo.points) cloud.push_back(sp.p_R0);
    refiner.insertKeyframe(static_cast<uint64_t>(i), static_cast<int64_t>(i) * 1'000'000'000,
                           bodyAt(i) * rig.T_B_R0, std::move(cloud), f.stereo, 3e-4, i == 0);
  }
  const FrameFeatures now = leg.frameAt(true_x, 100, rng);
  std::vector<Eigen::Vector3f> cloud;
  for (const auto& sp : now.stereo.points) cloud.push_back(sp.p_R0);
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Identity() * 1e-6;
  cov.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * sigma_m * sigma_m;
  return refiner.correct(now.stereo, cloud, 100, 100'000'000'000, bodyAt(estimated_x) * rig.T_B_R0, cov, rng);
}

TEST(GlobalRevisitDisc, OldGroundMetresFromThePredictionIsFoundAmongTheKeyframesOfTheDriftDisc) {
  // GIVEN a frame over x = 12 m of an old leg whose odometry has drifted 8 m ahead (x = 20 m),
  // with a 4 m position sigma: the three old keyframes nearest the prediction (20, 18 and
  // 22 m) do not overlap the ground under the vehicle (4.7 m footprint)
  const double true_x = 12.0, estimated_x = 20.0, sigma_m = 4.0;
  const Eigen::Vector3d truth = (Eigen::Isometry3d(Eigen::Translation3d(true_x, 0, 0)) *
                                 makeRectifier().rig().T_B_R0).translation();
  // WHEN only the nearest are tried (the earlier search)
  const GlobalCorrection nearest = revisitAfterLargeDrift(0, true_x, estimated_x, sigma_m);
  // THEN nothing is re-observed and the frame stays 8 m off
  EXPECT_FALSE(nearest.revisit_used);
  EXPECT_GT((nearest.T_W_R0.translation() - truth).norm(), 7.9);
  // WHEN the keyframes of the drift disc are ranked by descriptor matches first
  const GlobalCorrection ranked = revisitAfterLargeDrift(12, true_x, estimated_x, sigma_m);
  // THEN the old keyframe over the true ground is verified and pulls the frame back onto it
  ASSERT_TRUE(ranked.revisit_used);
  EXPECT_LT((ranked.T_W_R0.translation() - truth).norm(), 0.1);
  EXPECT_LT(ranked.covariance_scale, 0.01);
}

TEST(GlobalRevisitDisc, AFrameOverGroundNeverMappedIsNotPulledOntoTheKeyframesOfTheDisc) {
  // GIVEN the same old leg and a frame over ground the map never saw (other points, other
  // descriptors), which the odometry places on the leg with the same large uncertainty
  camera::StereoRectifier rect = makeRectifier();
  const camera::RectifiedRig rig = rect.rig();
  std::mt19937 rng(5);
  const test::SyntheticFloor leg = test::randomFloor(rng, 6000, -3.0, 40.0, 3.0, -4.0);
  const test::SyntheticFloor beside = test::randomFloor(rng, 600, 9.0, 15.0, 3.0, -4.0);
  std::normal_distribution<double> pix(0.0, 0.1);
  GlobalRefiner refiner(rig, globalRefinerParams(globalParams()));
  for (int i = 0; i <= 36; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(i, 0, 0);
    const FrameFeatures f = test::floorFrame(rig, leg.points_W, leg.descriptors, T, static_cast<uint64_t>(i),
                                             static_cast<int64_t>(i) * 1'000'000'000, pix, rng);
    refiner.insertKeyframe(static_cast<uint64_t>(i), static_cast<int64_t>(i) * 1'000'000'000, T * rig.T_B_R0, {},
                           f.stereo, 3e-4, i == 0);
  }
  Eigen::Isometry3d T_true = Eigen::Isometry3d::Identity();
  T_true.translation() = Eigen::Vector3d(12.0, 0, 0);
  const FrameFeatures now =
      test::floorFrame(rig, beside.points_W, beside.descriptors, T_true, 100, 100'000'000'000, pix, rng);
  ASSERT_GT(now.stereo.points.size(), 100u);
  Eigen::Isometry3d T_est = T_true;
  T_est.translation().x() = 20.0;
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Identity() * 1e-6;
  cov.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * 16.0;
  // WHEN the drift disc is searched
  const GlobalCorrection c =
      refiner.correct(now.stereo, {}, 100, 100'000'000'000, T_est * rig.T_B_R0, cov, rng);
  // THEN no keyframe passes the verification and the frame is left where the odometry put it
  EXPECT_FALSE(c.revisit_used);
  EXPECT_TRUE(c.T_W_R0.isApprox(T_est * rig.T_B_R0, 1e-12));
}

TEST(GlobalRevisitDisc, AJumpLargerThanTheCapNeedsASecondWitnessOneFrameOfItIsNotEnough) {
  // GIVEN re-observation keyframes every 6 m of an old leg (so a frame overlaps one of them
  // only) and frames over x = 12 and 12.5 m whose odometry has drifted 8 m ahead, sigma 4 m
  OldLeg leg;
  const camera::RectifiedRig& rig = leg.rig;
  std::mt19937& rng = leg.rng;
  OdometryParams p = globalParams();
  p.revisit_keyframe_distance_m = 6.0;
  const auto bodyAt = OldLeg::bodyAt;
  const auto makeRefiner = [&](const OdometryParams& params) {
    GlobalRefiner refiner(rig, globalRefinerParams(params));
    std::mt19937 map_rng(9);
    for (int i = 0; i <= 36; ++i) {
      const FrameFeatures f = leg.frameAt(i, static_cast<uint64_t>(i), map_rng);
      refiner.insertKeyframe(static_cast<uint64_t>(i), static_cast<int64_t>(i) * 1'000'000'000,
                             bodyAt(i) * rig.T_B_R0, {}, f.stereo, 3e-4, i == 0);
    }
    return refiner;
  };
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Identity() * 1e-6;
  cov.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * 16.0;
  const FrameFeatures first = leg.frameAt(12.0, 100, rng), second = leg.frameAt(12.5, 101, rng);
  const Eigen::Vector3d truth_second = (bodyAt(12.5) * rig.T_B_R0).translation();
  // WHEN the 8 m jump's cap is the drift's 3 sigma alone (the earlier gate: one witness)
  OdometryParams one = p;
  one.max_revisit_correction_m = 25.0;
  GlobalRefiner trusting = makeRefiner(one);
  // THEN the first frame's one old keyframe moves it
  EXPECT_TRUE(trusting.correct(first.stereo, {}, 100, 100'000'000'000, bodyAt(20.0) * rig.T_B_R0, cov, rng).revisit_used);
  // WHEN a jump beyond max_revisit_correction_m needs a second witness
  GlobalRefiner refiner = makeRefiner(p);
  const GlobalCorrection a =
      refiner.correct(first.stereo, {}, 100, 100'000'000'000, bodyAt(20.0) * rig.T_B_R0, cov, rng);
  // THEN one old keyframe is not enough: the frame stays where the odometry put it
  EXPECT_FALSE(a.revisit_used);
  EXPECT_TRUE(a.T_W_R0.isApprox(bodyAt(20.0) * rig.T_B_R0, 1e-12));
  // AND the next frame, shifted the same way by its own old keyframe, is moved onto the truth
  const GlobalCorrection b =
      refiner.correct(second.stereo, {}, 101, 101'000'000'000, bodyAt(20.5) * rig.T_B_R0, cov, rng);
  ASSERT_TRUE(b.revisit_used);
  EXPECT_LT((b.T_W_R0.translation() - truth_second).norm(), 0.1);
  // AND a witness older than revisit_witness_window_s does not count
  GlobalRefiner late = makeRefiner(p);
  EXPECT_FALSE(late.correct(first.stereo, {}, 100, 100'000'000'000, bodyAt(20.0) * rig.T_B_R0, cov, rng).revisit_used);
  EXPECT_FALSE(late.correct(second.stereo, {}, 101, 110'000'000'000, bodyAt(20.5) * rig.T_B_R0, cov, rng).revisit_used);
}

struct SurveyRun {
  std::vector<Eigen::Vector3d> est, truth;
  int changed = 0;
};

/// A stretch of the survey rendered with a rig whose baseline is `baseline_factor` times the
/// true one: the odometry overestimates the motion there by that factor, a drift of known size
/// that the map can take back once the survey returns over older ground.
struct Drift {
  double baseline_factor = 1.0;
  double from_s = 0, to_s = 0;  ///< frames with from_s <= t < to_s
};

/// The survey through an Odometry with `params`; with `delay_frames` > 0 the global step is
/// deferred and each correction applied 1..delay_frames frames after its frame (cycling), the
/// published estimate of a frame being its refined pose. `changed`: frames the map moved.
SurveyRun runSurvey(int delay_frames, OdometryParams params = globalParams(), int frames = 120, Drift drift = {},
                    double pixel_sigma = 0.3) {
  camera::StereoRectifier rect = makeRectifier();
  const camera::RectifiedRig rig = rect.rig();
  camera::RectifiedRig drift_rig = rig;
  drift_rig.baseline_m *= drift.baseline_factor;
  if (delay_frames > 0) params.global_delivery = GlobalDelivery::kDeferred;
  Odometry odo(std::move(rect), imu::ImuNoise{}, params);
  EXPECT_EQ(odo.deferredGlobal(), params.mode == Mode::kGlobal && delay_frames > 0);
  GlobalRefiner refiner = odo.makeGlobalRefiner();
  std::mt19937 refiner_rng(99);
  Survey survey(rig), drift_survey(drift_rig);
  struct Pending {
    int due = 0;
    GlobalCorrection c;
  };
  std::deque<Pending> pending;  // FIFO, like the daemon's correction ring
  SurveyRun run;  // 120 frames = 12 s at 10 Hz: out and back
  run.est.resize(static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    while (!pending.empty() && pending.front().due <= f) {
      odo.applyGlobalCorrection(pending.front().c);
      pending.pop_front();
    }
    const double t = 0.1 * f;
    std::vector<ImuSample> imu = survey.imuUntil(static_cast<int64_t>(std::llround(t * 1e9)));
    Survey& s = (t >= drift.from_s && t < drift.to_s) ? drift_survey : survey;
    const OdometryResult r = odo.track(s.frame(static_cast<uint64_t>(f), t, bodyPose(t), pixel_sigma), imu);
    run.truth.push_back(bodyPose(t).translation());
    run.est[f] = r.T_W_B.translation();
    if (r.quality.map_refined) ++run.changed;
    if (odo.deferredGlobal()) {
      EXPECT_EQ(r.quality.model_points, 0) << "deferred: no map work on the estimator";
      if (std::optional<GlobalRequest> q = odo.takeGlobalRequest()) {
        EXPECT_EQ(q->frame_id, static_cast<uint64_t>(f));
        // The published pose is the chain's (the daemon's contract)
        EXPECT_TRUE((q->T_W_R0 * rig.T_B_R0.inverse()).isApprox(r.T_W_B, 1e-9)) << "frame " << f;
        const GlobalCorrection c = refiner.refine(*q, refiner_rng);
        run.est[f] = (c.correction_W * r.T_W_B).translation();
        if (c.changed()) ++run.changed;
        pending.push_back({f + 1 + f % delay_frames, c});
      }
    }
  }
  return run;
}

double maxError(const SurveyRun& r) {
  double e = 0;
  for (std::size_t i = 0; i < r.est.size(); ++i) e = std::max(e, (r.est[i] - r.truth[i]).norm());
  return e;
}

TEST(OdometryDeferredGlobal, CorrectionsAppliedOneToThreeFramesLateTrackTheInlinePath) {
  // GIVEN the same revisit survey run inline and deferred (corrections 1-3 frames late)
  OdometryParams params = globalParams();
  const SurveyRun inline_run = runSurvey(0, params);
  const SurveyRun deferred = runSurvey(3, params);
  // THEN the map worked in both, and the refined trajectories stay close to each other and
  // as close to the truth
  EXPECT_GT(deferred.changed, 0);
  double max_diff = 0;
  for (std::size_t i = 0; i < inline_run.est.size(); ++i)
    max_diff = std::max(max_diff, (inline_run.est[i] - deferred.est[i]).norm());
  const double e_inline = maxError(inline_run), e_deferred = maxError(deferred);
  RecordProperty("max_diff_mm", static_cast<int>(max_diff * 1000));
  EXPECT_LT(max_diff, 0.03) << "inline max error " << e_inline << " m, deferred " << e_deferred << " m";
  EXPECT_LT(e_deferred, e_inline + 0.02);
  // AND with the filter on (the default) deferring still costs no accuracy
  const SurveyRun inline_filtered = runSurvey(0), deferred_filtered = runSurvey(3);
  EXPECT_GT(deferred_filtered.changed, 0);
  EXPECT_LT(maxError(deferred_filtered), maxError(inline_filtered) + 0.02);
}

TEST(OdometryDeferredGlobal, ACorrectionMovesTheCurrentPoseAndTheNextPrediction) {
  // GIVEN two identical deferred odometries on the same frames
  camera::StereoRectifier r1 = makeRectifier(), r2 = makeRectifier();
  const camera::RectifiedRig rig = r1.rig();
  OdometryParams params = globalParams();
  params.global_delivery = GlobalDelivery::kDeferred;
  Odometry a(std::move(r1), imu::ImuNoise{}, params), b(std::move(r2), imu::ImuNoise{}, params);
  Survey sa(rig), sb(rig);
  GlobalCorrection shift;
  shift.correction_W.translation() = Eigen::Vector3d(0.05, -0.02, 0.0);
  shift.revisit_used = true;
  shift.covariance_scale = 0.5;
  for (int f = 0; f < 30; ++f) {
    const double t = 0.1 * f;
    const int64_t t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    std::vector<ImuSample> ia = sa.imuUntil(t_ns), ib = sb.imuUntil(t_ns);
    // WHEN one of them gets a correction of (5, -2, 0) cm after frame 10
    if (f == 11) {
      b.applyGlobalCorrection(shift);
      EXPECT_NEAR((b.state().T_W_B.translation() - a.state().T_W_B.translation()).x(), 0.05, 1e-9);
    }
    const OdometryResult ra = a.track(sa.frame(static_cast<uint64_t>(f), t, bodyPose(t), 0.0), ia);
    const OdometryResult rb = b.track(sb.frame(static_cast<uint64_t>(f), t, bodyPose(t), 0.0), ib);
    if (f >= 11) {
      // THEN every later pose carries it: the tensor chains on the corrected pose
      const Eigen::Vector3d d = rb.T_W_B.translation() - ra.T_W_B.translation();
      EXPECT_NEAR(d.x(), 0.05, 2e-3) << "frame " << f;
      EXPECT_NEAR(d.y(), -0.02, 2e-3) << "frame " << f;
      if (f == 11) {
        const double var_a = ra.covariance.bottomRightCorner<3, 3>().trace();
        const double var_b = rb.covariance.bottomRightCorner<3, 3>().trace();
        EXPECT_LT(var_b, var_a);
      }
    }
    EXPECT_TRUE(a.takeGlobalRequest().has_value()) << "frame " << f;
    (void)b.takeGlobalRequest();
  }
  EXPECT_EQ(b.revisitCorrections(), 1);
}

// --- Keyframe tracking in global mode: at 1 Hz and 1.5 m per frame previous-frame
// tracking broke down on the paper survey, so global mode tracks against keyframes as local
// mode does, and a map correction moves the keyframe with the frame.

OdometryParams localParams() {
  OdometryParams p = globalParams();
  p.mode = Mode::kLocal;
  return p;
}

/// 8 % too much motion from 2 to 4 s on the way out: ~16 cm of drift by the turn.
constexpr Drift kOutboundDrift{1.08, 2.0, 4.0};

/// The drifted survey's parameters: vision only. The drift is a stereo baseline 8 % off, which
/// the IMU contradicts: the inertial gate refuses the first drifted frames and the fault rule
/// then follows vision, so with the IMU the drift depends on the gate's timing, not on what
/// these tests are about (how a map correction travels with the keyframe chain).
OdometryParams driftedParams(OdometryParams p) {
  p.prediction = Prediction::kConstantVelocity;
  return p;
}

TEST(GlobalKeyframe, WithoutOldGroundGlobalModeTracksExactlyAsLocalMode) {
  // GIVEN the first 5 s of the survey, none of it old enough to be a revisit
  OdometryParams frame_to_frame = globalParams();
  frame_to_frame.keyframe_tracking = false;
  ASSERT_TRUE(globalParams().keyframe_tracking);
  // WHEN local mode, global mode and global mode without keyframes run over it
  const SurveyRun l = runSurvey(0, localParams(), 50), g = runSurvey(0, globalParams(), 50),
                  f = runSurvey(0, frame_to_frame, 50);
  // THEN global mode places every frame exactly where local mode does: it tracks against the
  // same keyframes; frame-to-frame tracking is a different chain
  EXPECT_EQ(g.changed, 0);
  double max_diff = 0, max_diff_f = 0;
  for (std::size_t i = 0; i < l.est.size(); ++i) {
    max_diff = std::max(max_diff, (g.est[i] - l.est[i]).norm());
    max_diff_f = std::max(max_diff_f, (f.est[i] - l.est[i]).norm());
  }
  EXPECT_EQ(max_diff, 0.0);
  EXPECT_GT(max_diff_f, 1e-5);
}

TEST(GlobalKeyframe, MapCorrectionsStayWithTheChainTrackedAgainstTheKeyframe) {
  // GIVEN the out-and-back survey with the motion overestimated by 8 % from 2 to 4 s on the way
  // out (a drift of ~16 cm), and the way back re-observing the first metre, mapped before it
  // WHEN local and (inline) global mode run over it
  const SurveyRun l = runSurvey(0, driftedParams(localParams()), 120, kOutboundDrift, 0.2);
  const SurveyRun g = runSurvey(0, driftedParams(globalParams()), 120, kOutboundDrift, 0.2);
  const double local_final = (l.est.back() - l.truth.back()).norm();
  const double global_final = (g.est.back() - g.truth.back()).norm();
  RecordProperty("local_final_mm", static_cast<int>(local_final * 1000));
  RecordProperty("global_final_mm", static_cast<int>(global_final * 1000));
  // THEN the drift is there without the map and the map takes it back...
  EXPECT_GT(local_final, 0.08);
  EXPECT_GT(g.changed, 0);
  EXPECT_LT(global_final, 0.3 * local_final) << "local " << local_final << " m";
  // ...and keeps it: every frame after the first that the map pulled in stays pulled in (a
  // keyframe left behind would place the next frames where the drifted odometry had them)
  std::size_t first = g.est.size();
  for (std::size_t i = 0; i < g.est.size() && first == g.est.size(); ++i)
    if ((g.est[i] - g.truth[i]).norm() < 0.3 * (l.est[i] - l.truth[i]).norm()) first = i;
  ASSERT_LT(first + 3, g.est.size()) << "the map never pulled the drift in";
  for (std::size_t i = first; i < g.est.size(); ++i)
    EXPECT_LT((g.est[i] - g.truth[i]).norm(), 0.3 * (l.est[i] - l.truth[i]).norm()) << "frame " << i;
}

TEST(GlobalKeyframe, DeferredCorrectionsOfFramesTrackedBeforeTheFirstLandsAreNotAppliedTwice) {
  // GIVEN the drifted survey with the global step deferred, its corrections landing 1-3
  // frames late, so the frames after a re-observation are refined before it reached the state
  const SurveyRun l = runSurvey(0, driftedParams(localParams()), 120, kOutboundDrift, 0.2);
  const SurveyRun inline_run = runSurvey(0, driftedParams(globalParams()), 120, kOutboundDrift, 0.2);
  const SurveyRun deferred = runSurvey(3, driftedParams(globalParams()), 120, kOutboundDrift, 0.2);
  // THEN each frame's correction is only what earlier ones have not yet delivered: the
  // deferred path takes the drift back as the inline one does, without overshooting it
  const double local_final = (l.est.back() - l.truth.back()).norm();
  EXPECT_GT(local_final, 0.08);
  EXPECT_GT(deferred.changed, 0);
  double worst_after = 0;
  for (std::size_t i = deferred.est.size() - 5; i < deferred.est.size(); ++i)
    worst_after = std::max(worst_after, (deferred.est[i] - deferred.truth[i]).norm());
  EXPECT_LT(worst_after, 0.3 * local_final);
  EXPECT_LT((deferred.est.back() - inline_run.est.back()).norm(), 0.02);
}

}  // namespace
}  // namespace global_refiner_test
}  // namespace seavio::odometry
