// 1 Hz vision losses end to end: `Odometry` itself, as `seavio run` drives it, over a
// synthetic 1 Hz survey whose frames go textureless for a stretch while the IMU goes on. The
// IMU carries a leak (an accelerometer bias that appears after the still start, so the levelling
// cannot absorb it as tilt): the steady fixes before the loss either agree on it (a constant
// bias: the coasting is corrected by it, core/imu/coasting_leak.hpp) or not (a bias turning
// every second: only the coasting covariance widens). Each is run with the leak correction on
// and off (coasting_leak_correction), so the test shows what the correction buys and fails if
// it stops doing so; OdometryResult::coasting says which losses were corrected and how.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/imu/imu_integrator.hpp"
#include "core/odometry/odometry.hpp"
#include "tests/core/odometry/downward_rig.hpp"
#include "tests/core/odometry/floor_frame.hpp"

namespace seavio::odometry {
namespace coasting_loss_test {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSpeed = 1.5;   // [m/s] along x, level: the full paper survey's 1.5 m per frame
constexpr int kFrames = 22;      // 1 Hz, t = 0 .. 21 s
constexpr int kLossFrom = 10;    // frames 10..14 are textureless (no features at all)
constexpr int kLossFrames = 5;
/// The first textured frame after the loss has nothing to be matched against (its reference
/// is the last textureless frame), so it coasts too: IMU-only frames are 10..15.
constexpr int kLostTo = kLossFrom + kLossFrames;

/// The accelerometer bias in the body (= W: level, heading 0) over the IMU interval ending at
/// frame `k` (samples in (k-1, k] s); zero up to t = 0, so the still start levels exactly.
enum class Leak { kConstant, kTurning };
Eigen::Vector3d accelBias(Leak leak, int64_t t_ns) {
  if (t_ns <= 0) return Eigen::Vector3d::Zero();
  if (leak == Leak::kConstant) return Eigen::Vector3d(0.3, -0.1, 0.0);
  // A bias turning by 90 deg every second: consecutive fixes' innovations point four ways and
  // no three of five agree.
  const auto k = static_cast<int>((t_ns + 999'999'999) / 1'000'000'000);
  return 0.4 * Eigen::Vector3d(std::cos(0.5 * kPi * k), std::sin(0.5 * kPi * k), 0.0);
}

struct LossRun {
  std::vector<OdometryResult> results;
  std::vector<double> error_m;        ///< per frame: |estimated - true position| [m]
  double max_lost_error_m = 0;        ///< over the IMU-only frames
  double error_before_loss_m = 0;     ///< at the last fix before the loss
  bool all_finite = true;             ///< pose, velocity and covariance of every frame
};

LossRun fly(Leak leak, bool correction) {
  std::string error;
  auto rectifier = camera::StereoRectifier::create(test::downwardRig(), &error);
  EXPECT_TRUE(rectifier.has_value()) << error;
  const camera::RectifiedRig rig = rectifier->rig();
  OdometryParams params;  // the defaults `seavio run` uses, but for the switch under test
  params.coasting_leak_correction = correction;
  Odometry odo(std::move(*rectifier), imu::ImuNoise{}, params);

  std::mt19937 rng(11);
  std::normal_distribution<double> pix(0.0, 0.1);
  const double length = kSpeed * (kFrames - 1);
  const test::SyntheticFloor floor =
      test::randomFloor(rng, static_cast<int>(160 * (length + 19.0)), -3.0, length + 16.0, 3.0, -4.0);

  LossRun out;
  int64_t imu_t = -1'000'000'000;
  for (int f = 0; f < kFrames; ++f) {
    const int64_t t_ns = int64_t{1'000'000'000} * f;
    std::vector<ImuSample> imu;
    for (; imu_t <= t_ns + 5'000'000; imu_t += 5'000'000) {
      ImuSample s;
      s.t_ns = imu_t;
      s.accel_m_s2 = -imu::gravityW() + accelBias(leak, imu_t);
      imu.push_back(s);
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(kSpeed * f, 0, 0);
    FrameFeatures ff;
    if (f >= kLossFrom && f < kLossFrom + kLossFrames) {
      ff.t_ns = t_ns;  // textureless: the frontend found nothing
      ff.seq = static_cast<uint64_t>(f);
    } else {
      ff = test::floorFrame(rig, floor.points_W, floor.descriptors, T, static_cast<uint64_t>(f), t_ns, pix, rng);
    }
    const OdometryResult r = odo.track(std::move(ff), imu);
    out.all_finite = out.all_finite && r.T_W_B.matrix().allFinite() && r.v_W.allFinite() && r.covariance.allFinite();
    const double e = (r.T_W_B.translation() - T.translation()).norm();
    out.error_m.push_back(e);
    if (r.source == PoseSource::kImuOnly) out.max_lost_error_m = std::max(out.max_lost_error_m, e);
    if (f == kLossFrom - 1) out.error_before_loss_m = e;
    out.results.push_back(r);
  }
  return out;
}

double positionSigma(const OdometryResult& r) {
  return std::sqrt(r.covariance.bottomRightCorner<3, 3>().trace());
}

/// The frames flagged IMU-only must be exactly the loss stretch (and the frame after it), all
/// with coasting `expected`; every other frame after the first is visual with coasting kNone.
void expectLossFlagged(const LossRun& run, CoastingCorrection expected) {
  ASSERT_EQ(run.results.size(), static_cast<std::size_t>(kFrames));
  for (int f = 1; f < kFrames; ++f) {
    const OdometryResult& r = run.results[static_cast<std::size_t>(f)];
    if (f >= kLossFrom && f <= kLostTo) {
      EXPECT_EQ(r.source, PoseSource::kImuOnly) << "frame " << f;
      EXPECT_EQ(r.coasting, expected) << "frame " << f;
    } else {
      EXPECT_EQ(r.source, PoseSource::kVision) << "frame " << f;
      EXPECT_EQ(r.coasting, CoastingCorrection::kNone) << "frame " << f;
    }
  }
}

TEST(CoastingLoss, At1HzALossIsCorrectedByTheLeakTheSteadyFixesAgreeOnAndFlaggedSo) {
  // GIVEN a 1 Hz survey, 1.5 m per frame, with a constant 0.32 m/s^2 accelerometer bias from
  // t = 0 and 5 textureless frames after 9 visual ones
  // WHEN the odometry runs over it with the leak correction (the default) and without it
  const LossRun on = fly(Leak::kConstant, true);
  const LossRun off = fly(Leak::kConstant, false);
  RecordProperty("max_coasted_error_mm_corrected", static_cast<int>(1e3 * on.max_lost_error_m));
  RecordProperty("max_coasted_error_mm_bare", static_cast<int>(1e3 * off.max_lost_error_m));
  for (int f = kLossFrom - 1; f <= kLostTo + 1; ++f)
    std::printf("[ frame %2d ] error corrected %.3f m, bare %.3f m\n", f, on.error_m[static_cast<std::size_t>(f)],
                off.error_m[static_cast<std::size_t>(f)]);
  // THEN the lost frames (and the first textured one, which has no reference) are flagged
  // IMU-only, corrected by the agreed leak, and bare without the correction
  expectLossFlagged(on, CoastingCorrection::kAgreedLeak);
  expectLossFlagged(off, CoastingCorrection::kBare);
  // AND no NaN leaves core
  EXPECT_TRUE(on.all_finite);
  EXPECT_TRUE(off.all_finite);
  // AND up to the loss both runs are the same (the correction only acts on lost frames)
  EXPECT_EQ(on.error_before_loss_m, off.error_before_loss_m);
  EXPECT_LT(on.error_before_loss_m, 0.05);
  // AND the bare coasting misses by the leak's k x a x dt^2 per step (~0.3 m, 0.6 m, ... : metres
  // after 6 frames), while the corrected coasting stays within a tenth of that and a few dm
  EXPECT_GT(off.max_lost_error_m, 2.0);
  EXPECT_LT(on.max_lost_error_m, 0.1 * off.max_lost_error_m);
  EXPECT_LT(on.max_lost_error_m, 0.25);
  // AND vision takes over after the loss (expectLossFlagged) from where the coasting left the
  // chain (local odometry: nothing moves it back), so the corrected run ends where it coasted to
  EXPECT_LT(on.error_m.back(), 0.25);
  EXPECT_GT(off.error_m.back(), 2.0);
}

TEST(CoastingLoss, At1HzFixesThatDisagreeCorrectNothingAndOnlyWidenTheCovariance) {
  // GIVEN the same survey, but a 0.4 m/s^2 accelerometer bias that turns by 90 deg every second
  // WHEN the odometry runs over it with the leak correction and without it
  const LossRun on = fly(Leak::kTurning, true);
  const LossRun off = fly(Leak::kTurning, false);
  // THEN the lost frames are flagged IMU-only, covariance-only with the correction on
  expectLossFlagged(on, CoastingCorrection::kCovarianceOnly);
  expectLossFlagged(off, CoastingCorrection::kBare);
  EXPECT_TRUE(on.all_finite);
  EXPECT_TRUE(off.all_finite);
  // AND their poses are the bare coasting's, but the position sigma claimed grew with the leak
  // the fixes measured
  for (int f = kLossFrom; f <= kLostTo; ++f) {
    const OdometryResult& a = on.results[static_cast<std::size_t>(f)];
    const OdometryResult& b = off.results[static_cast<std::size_t>(f)];
    EXPECT_LT((a.T_W_B.translation() - b.T_W_B.translation()).norm(), 1e-9) << "frame " << f;
    EXPECT_GT(positionSigma(a), positionSigma(b)) << "frame " << f;
  }
  RecordProperty("last_coasted_sigma_mm_covariance_only",
                 static_cast<int>(1e3 * positionSigma(on.results[static_cast<std::size_t>(kLostTo)])));
  RecordProperty("last_coasted_sigma_mm_bare",
                 static_cast<int>(1e3 * positionSigma(off.results[static_cast<std::size_t>(kLostTo)])));
}

}  // namespace
}  // namespace coasting_loss_test
}  // namespace seavio::odometry
