#pragma once
/// Error covariance of IMU dead reckoning through a vision outage (paper section III-A
/// for the propagation itself).
///
/// Per-frame propagation from a fresh visual fix (imu::propagate) is right for the matching
/// windows, but summing its per-interval position covariances over many coasting frames treats
/// every interval as independent: a velocity error integrates into position linearly in time
/// and an accelerometer-bias or tilt error quadratically, and neither shows up if the
/// correlations are dropped at every frame. This keeps one 15-state error covariance from the
/// last visual fix to the current coasting frame instead, with the error sources that dominate
/// there: the velocity and attitude uncertainty handed over by vision, the gyro and
/// accelerometer bias uncertainty (the accelerometer bias is not estimated, so its whole
/// spread counts) and their random walks.
#include <span>

#include <Eigen/Core>

#include "core/common/types.hpp"
#include "core/imu/imu_noise.hpp"

namespace seavio::imu {

/// Error-state order: dtheta [rad] in body, dv [m/s] in W, dp [m] in W, gyro bias [rad/s],
/// accelerometer bias [m/s^2].
using Matrix15d = Eigen::Matrix<double, 15, 15>;
/// Internally a 16th-18th state: the error of the acceleration correction [m/s^2, W], constant
/// in W (zero without a correction).
using Matrix18d = Eigen::Matrix<double, 18, 18>;

/// One-sigma uncertainties at the start of a vision outage (per axis).
struct CoastingStart {
  double attitude_sigma_rad = 0.005;
  double velocity_sigma_m_s = 0.05;
  double gyro_bias_sigma_rad_s = 3e-4;
  double accel_bias_sigma_m_s2 = 0.03;
};

class CoastingCovariance {
 public:
  /// Starts an outage at the last visual fix: position error zero (the fix's own covariance
  /// is the caller's), the rest from `s`.
  void start(const CoastingStart& s);
  /// After start(): velocity and the acceleration the IMU missed, both measured by a parabola
  /// fit over visual fixes (HandoverVelocity::has_acceleration), in W. The dead reckoning is
  /// then corrected by `acceleration_error` (accelerationCorrection()), a constant in W. Its
  /// error c = -H x + e cancels what the tilt error and the bias's vertical component do at
  /// attitude `R_W_B` (both stay constant in W as the vehicle turns about the vertical), up to
  /// the fit's own error e (correlated with the velocity); the horizontal bias prior stays on
  /// top (it turns with the heading, the correction does not).
  void setMeasuredMotion(const Eigen::Matrix3d& velocity_covariance, const Eigen::Matrix3d& velocity_acceleration_covariance,
                         const Eigen::Matrix3d& acceleration_covariance, const Eigen::Vector3d& acceleration_error,
                         const Eigen::Matrix3d& R_W_B);
  /// The acceleration in W to add to the dead reckoning while coasting [m/s^2] (zero unless
  /// setMeasuredMotion set it).
  const Eigen::Vector3d& accelerationCorrection() const { return accel_correction_W_; }
  /// After start(): the velocity error is that of a velocity measured over a window of visual
  /// fixes (core/imu/coasting_handover.hpp) instead of `velocity_sigma_m_s`: `velocity_covariance`
  /// [m^2/s^2, W] at the fixes' mean time, `age_s` before the start, carried to the start by
  /// the error dynamics of the IMU increments it was computed with, so the tilt and
  /// accelerometer-bias errors that bent them stay correlated with it. `R_W_B` and
  /// `specific_force_B` [m/s^2] are the attitude and IMU reading at the start.
  void setMeasuredVelocity(const Eigen::Matrix3d& velocity_covariance, double age_s, const Eigen::Matrix3d& R_W_B,
                           const Eigen::Vector3d& specific_force_B);
  /// Ends the outage (vision is back).
  void stop() { active_ = false; }
  bool active() const { return active_; }

  /// Grows the covariance over [t0_ns, t1_ns] along the nominal path that starts at attitude
  /// `R_W_B` with the given bias estimates, using `samples` (sorted; interpolated at the
  /// knots, held beyond the ends, as imu::propagate does).
  void propagate(const Eigen::Matrix3d& R_W_B, const Eigen::Vector3d& gyro_bias, const Eigen::Vector3d& accel_bias,
                 std::span<const ImuSample> samples, int64_t t0_ns, int64_t t1_ns, const ImuNoise& noise);

  /// Pose covariance added since the outage began, tangent order (rotation, translation) in W,
  /// for a body attitude `R_W_B` now.
  Eigen::Matrix<double, 6, 6> poseCovariance(const Eigen::Matrix3d& R_W_B) const;

  /// The 15 error states' covariance.
  Matrix15d covariance() const { return P_.topLeftCorner<15, 15>(); }

 private:
  Matrix18d P_ = Matrix18d::Zero();
  Eigen::Vector3d accel_correction_W_ = Eigen::Vector3d::Zero();
  bool active_ = false;
};

}  // namespace seavio::imu
