// The gyro bias learnt by the inertial filter from vision (local keyframe tracking): a bias the
// start could not see (it appears once the vehicle moves) is learnt from each frame's
// prior-free four-view motion, to within the filter's own three sigma.
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Cholesky>

#include <gtest/gtest.h>

#include "core/imu/imu_integrator.hpp"
#include "core/odometry/odometry.hpp"
#include "tests/core/odometry/downward_rig.hpp"
#include "tests/core/odometry/floor_frame.hpp"

namespace seavio::odometry {
namespace gyro_bias_test {
namespace {

constexpr double kSpeed = 1.0;  // [m/s], level flight along x, 4 m above the floor

struct BiasRun {
  Eigen::Vector3d final_bias_error = Eigen::Vector3d::Zero();  ///< learnt minus true [rad/s]
  Eigen::Vector3d final_bias_sigma = Eigen::Vector3d::Zero();  ///< the filter's own [rad/s]
  double final_attitude_error_rad = 0;
  int vision_frames = 0;
  Eigen::Vector3d result_bias_sigma = Eigen::Vector3d::Zero();  ///< the last result's [rad/s]
  int claimed_increments = 0;  ///< results with a positive-definite increment covariance
  bool first_claims_increment = true;
};

/// 12 s over a synthetic floor; the gyro reads `bias` from t = 0 on (after the still second
/// that initialises the odometry, so the still-start estimate is zero).
BiasRun fly(const Eigen::Vector3d& bias) {
  std::string error;
  auto rectifier = camera::StereoRectifier::create(test::downwardRig(), &error);
  EXPECT_TRUE(rectifier.has_value()) << error;
  const camera::RectifiedRig rig = rectifier->rig();
  const OdometryParams params;
  Odometry odo(std::move(*rectifier), imu::ImuNoise{}, params);

  std::mt19937 rng(11);
  std::normal_distribution<double> pix(0.0, 0.1);
  const test::SyntheticFloor floor = test::randomFloor(rng, 3000, -3.0, 16.0, 3.0, -4.0);
  const auto pose = [](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(kSpeed * t, 0, 0);
    return T;
  };

  BiasRun out;
  const int frames = 120;
  int64_t imu_t = -1'000'000'000;
  Eigen::Matrix3d R_last = Eigen::Matrix3d::Identity();
  for (int f = 0; f < frames; ++f) {
    const double t = 0.1 * f;
    const int64_t t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    const std::vector<ImuSample> imu = test::levelImuUntil(imu_t, t_ns, bias);
    FrameFeatures ff = test::floorFrame(rig, floor.points_W, floor.descriptors, pose(t), static_cast<uint64_t>(f), t_ns, pix, rng);
    EXPECT_GT(ff.stereo.points.size(), 100u);
    const OdometryResult r = odo.track(std::move(ff), imu);
    out.vision_frames += r.source == PoseSource::kVision;
    if (f == 0) out.first_claims_increment = !r.increment_covariance.isZero(0.0);
    out.claimed_increments += Eigen::LLT<Eigen::Matrix<double, 6, 6>>(r.increment_covariance).info() == Eigen::Success &&
                              !r.increment_covariance.isZero(0.0);
    out.result_bias_sigma = r.gyro_bias_sigma_rad_s;
    R_last = r.T_W_B.linear();
  }
  out.final_bias_error = odo.state().gyro_bias_rad_s - bias;
  const imu::EsMatrix& P = odo.inertial().covariance();
  for (int i = 0; i < 3; ++i) out.final_bias_sigma[i] = std::sqrt(P(imu::kEsBg + i, imu::kEsBg + i));
  out.final_attitude_error_rad = Eigen::AngleAxisd(R_last).angle();  // truth: identity
  return out;
}

TEST(GyroBiasLearning, AnUnseenBiasIsLearntWithinTheFiltersThreeSigma) {
  // GIVEN a gyro bias of 1 mrad/s about each axis that the still start did not see
  const Eigen::Vector3d bias(1e-3, -1e-3, 1e-3);
  // WHEN the odometry flies 12 s over a textured floor
  const BiasRun run = fly(bias);
  RecordProperty("bias_error_urad_s", static_cast<int>(1e6 * run.final_bias_error.norm()));
  RecordProperty("attitude_error_urad", static_cast<int>(1e6 * run.final_attitude_error_rad));
  // THEN every frame is visual, most of the bias is learnt, each axis within the filter's own
  // 3 sigma, and the attitude keeps well under what the bias, unlearnt, would have turned
  // over the 12 s (20 mrad)
  EXPECT_EQ(run.vision_frames, 119);  // all but the first (initialising) frame
  EXPECT_LT(run.final_bias_error.norm(), 0.3 * bias.norm());
  for (int i = 0; i < 3; ++i) EXPECT_LT(std::abs(run.final_bias_error[i]), 3 * run.final_bias_sigma[i]) << i;
  EXPECT_LT(run.final_attitude_error_rad, 0.35 * bias.norm() * 12.0);
  // AND each result carries the filter's bias sigma and, from the second frame on, the
  // covariance its visual increment claims (none for the first frame: there is no increment)
  EXPECT_TRUE(run.result_bias_sigma.isApprox(run.final_bias_sigma, 1e-12)) << run.result_bias_sigma.transpose();
  EXPECT_EQ(run.claimed_increments, 119);
  EXPECT_FALSE(run.first_claims_increment);
}

}  // namespace
}  // namespace gyro_bias_test
}  // namespace seavio::odometry
