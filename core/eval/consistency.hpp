#pragma once
/// Whether the odometry's claimed uncertainty fits its errors against ground truth: the
/// inertial filter's biases against a simulator's true biases, within the filter's own sigmas,
/// and the normalised estimation error squared (NEES) of each published frame-to-frame pose
/// increment under the covariance the estimate claims for it (OdometryResult).
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/covariance.hpp"

namespace seavio::eval {

/// One ground-truth sample: the body (IMU) pose in the truth's world and the true biases.
struct TruthSample {
  int64_t t_ns = 0;
  Eigen::Isometry3d T_W_B = Eigen::Isometry3d::Identity();
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();
};

/// One published frame as the checks read it.
struct ConsistencyFrame {
  int64_t t_ns = 0;
  Eigen::Isometry3d T_W_B = Eigen::Isometry3d::Identity();  ///< in the estimate's own world
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();
  /// The filter's 1-sigma per axis; zero: no claim (no IMU), the frame is left out.
  Eigen::Vector3d gyro_bias_sigma_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_sigma_m_s2 = Eigen::Vector3d::Zero();
  /// OdometryResult::increment_covariance: the increment since the previous frame; zero: not a
  /// visual increment, the frame is left out of the NEES.
  Matrix6d increment_covariance = Matrix6d::Zero();
};

struct ConsistencyParams {
  /// Biases are judged on the frames at least this long after the first frame [s].
  double bias_settle_s = 30.0;
  double bias_sigmas = 3.0;  ///< "within": |estimate - truth| <= this many of the filter's sigmas
  /// The two-sided 95 % band of the chi-square distribution with 6 degrees of freedom.
  double nees_low = 1.237, nees_high = 14.449;
  int64_t max_interp_gap_ns = 200'000'000;  ///< truth samples further apart are not interpolated
  int64_t max_dt_ns = 5'000'000;            ///< ... and the nearest one must be this close
};

/// The NEES of one increment, with the 3-dof marginals of its rotation and translation.
struct IncrementNees {
  bool ok = false;  ///< false: the claimed covariance is not positive definite
  double full = 0, rotation = 0, translation = 0;
};

/// The error of the estimated increment `est_prev_curr` (T_W_B(prev)^-1 T_W_B(curr)) against
/// the true one, in RelativeMotion's convention (rotation Log(R_true^T R_est), a right
/// perturbation in the current body; translation p_est - p_true in the previous body),
/// weighted by the inverse of the claimed covariance `cov` in that order.
IncrementNees incrementNees(const Eigen::Isometry3d& est_prev_curr, const Eigen::Isometry3d& true_prev_curr,
                            const Matrix6d& cov);

struct ConsistencyFigures {
  /// The biases could be judged: the truth carries them (not all zero, as a real recording
  /// that does not know them writes), the run lasted bias_settle_s, and the filter claimed a
  /// sigma on at least one frame after that.
  bool bias_known = false;
  int bias_frames = 0;              ///< frames judged
  double bias_within_fraction = 0;  ///< of those, all six components within bias_sigmas
  int nees_frames = 0;              ///< visual increments with truth at both ends
  double nees_in_band_fraction = 0; ///< of those, NEES within [nees_low, nees_high]
  /// Medians of the 6-dof NEES (chi-square median 5.35 if the claim fits) and of the rotation
  /// and translation 3-dof marginals (2.37).
  double nees_median = 0, nees_rotation_median = 0, nees_translation_median = 0;
  std::vector<double> nees;  ///< per visual increment, in frame order
};

/// Both checks over `frames` (sorted by time) against `truth` (sorted by time; interpolated
/// at each frame, linear and slerp). Never throws; with nothing to judge the figures are zero.
ConsistencyFigures evaluateConsistency(const std::vector<TruthSample>& truth,
                                       const std::vector<ConsistencyFrame>& frames,
                                       const ConsistencyParams& params = {});

}  // namespace seavio::eval
