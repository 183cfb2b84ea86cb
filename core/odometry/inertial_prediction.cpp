/// Odometry's first stage (paper III-A): the inertial estimator propagated through the
/// interval; its motion since the previous frame, with its covariance (gyro noise, velocity,
/// tilt and bias uncertainty as the filter holds them), is the prediction.
#include "core/common/se3.hpp"
#include "core/odometry/odometry.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {
namespace {

/// The inertial estimator's predicted motion as a body transform (previous <- current).
Eigen::Isometry3d bodyMotion(const imu::RelativeMotion& m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = m.R_prev_curr;
  T.translation() = m.p_prev_curr;
  return T;
}

}  // namespace

void Odometry::bufferImu(std::span<const ImuSample> imu) {
  // Kept across calls so integration can interpolate at the frame boundaries.
  for (const ImuSample& s : imu)
    if (imu_buffer_.empty() || s.t_ns > imu_buffer_.back().t_ns) imu_buffer_.push_back(s);
}

MotionPrediction Odometry::predict(int64_t t_ns) {
  const Eigen::Isometry3d& T_B_R0 = frontend_.rig().T_B_R0;
  MotionPrediction p;
  p.dt_s = 1e-9 * static_cast<double>(t_ns - state_.t_ns);
  p.have_imu = filter_.started() && imu_buffer_.size() >= 2 && imu_buffer_.back().t_ns >= state_.t_ns;
  if (p.have_imu && filter_stale_) {
    // The IMU came back after an outage (or after a start without samples): the filter
    // starts again from the visual state, its inertial states at their start-up spread.
    filter_.startFrom(state_);
    filter_stale_ = false;
  }
  if (filter_.started() && !p.have_imu) filter_stale_ = true;
  if (p.have_imu) {
    filter_.propagate(imu_buffer_, t_ns);
    const imu::RelativeMotion inertial = filter_.predictedMotion();
    p.T_prev_curr_B = bodyMotion(inertial);
    p.T_prev_curr = orthonormalized(T_B_R0.inverse() * p.T_prev_curr_B * T_B_R0);
    p.covariance = imu::bodyToCameraMotionCovariance(inertial.covariance, p.T_prev_curr, T_B_R0);
  } else {
    // No IMU (KITTI, an IMU outage, or vision-only by choice): constant-velocity prediction,
    // loosely trusted.
    const double scale = last_dt_s_ > 0 ? p.dt_s / last_dt_s_ : 1.0;
    p.T_prev_curr = se3::expSE3(se3::logSE3(last_motion_) * scale);
    p.covariance = Matrix6d::Zero();
    p.covariance.diagonal() << 4e-4, 4e-4, 4e-4, 0.01, 0.01, 0.01;
  }
  // Drop what is no longer needed (keeping one sample before the frame for interpolation).
  while (imu_buffer_.size() > 2 && imu_buffer_[1].t_ns <= t_ns) imu_buffer_.erase(imu_buffer_.begin());
  return p;
}

}  // namespace seavio::odometry
