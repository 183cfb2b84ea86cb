/// Odometry's verdict on a visual pose: refused when it implies a speed the rig never reaches,
/// or when the inertial estimator's chi-square gate rejects its motion (paper III-A: the IMU
/// checks vision as vision corrects the IMU). A refused frame coasts, flagged, with the reason.
#include "core/odometry/increment_covariance.hpp"
#include "core/odometry/odometry.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {
namespace {

/// A vision-only motion against the reference (keyframe or previous frame), as the inertial
/// estimator's measurement between the previous frame's body pose and the current one.
/// `T_prev_ref` (rig frames) carries it from the reference to the previous frame; its error is
/// the keyframe's shared one, so frames through one keyframe telescope and the filter, which
/// takes each increment with the whole covariance, errs on the cautious side.
imu::RelativeMotion visionMotionSincePrevious(const MotionRefinementResult& vision, const Eigen::Isometry3d& T_prev_ref,
                                              const Eigen::Isometry3d& T_B_R0) {
  const Eigen::Isometry3d T_prev_curr = T_prev_ref * vision.T_prev_curr;
  imu::RelativeMotion z;
  const Eigen::Isometry3d T_B = T_B_R0 * T_prev_curr * T_B_R0.inverse();
  z.R_prev_curr = T_B.rotation();
  z.p_prev_curr = T_B.translation();
  z.covariance = bodyCovarianceSincePrevious(vision.covariance, T_prev_ref, T_prev_curr, T_B_R0);
  return z;
}

}  // namespace

void Odometry::acceptFrame(FrameTrack& t, OdometryResult& r) {
  const Eigen::Isometry3d& T_B_R0 = frontend_.rig().T_B_R0;
  const PreviousFrame& prev = *previous_;
  t.T_W_R0 = orthonormalized(t.T_W_R0);
  t.T_W_B = orthonormalized(t.T_W_R0 * T_B_R0.inverse());
  const double dt_s = t.prediction.dt_s;
  if (t.vision_ok && dt_s > 0) {
    // Faster than the rig ever moves (its profile, with a margin): a wrong solution.
    const double speed_m_s = (t.T_W_B.translation() - t.map_shift_W - state_.T_W_B.translation()).norm() / dt_s;
    const double limit_m_s = params_.rig.max_speed_m_s * params_.speed_margin;
    if (speed_m_s > limit_m_s) {
      t.vision_ok = false;  // a jump: refuse it rather than publish it
      t.refusal = {Refusal::kSpeed, speed_m_s, limit_m_s};
    }
  }
  // The inertial estimator takes the vision-only motion since the previous frame, through its
  // chi-square gate; a refused motion is not used for the pose either (the frame coasts,
  // flagged). Against a keyframe older than a coasted previous frame the motion would carry
  // that frame's prediction into the measurement: the filter then only moves its clone on.
  t.reference_measured = !previous_coasted_ || !t.reference.on_keyframe || keyframe_->t_ns == prev.t_ns;
  if (!t.prediction.have_imu || !t.vision_ok || !t.vision_alone || !t.reference_measured) return;
  const imu::RelativeMotion z =
      visionMotionSincePrevious(*t.vision_alone, prev.T_W_R0.inverse() * t.reference.T_W_ref, T_B_R0);
  double d2 = 0;
  const imu::UpdateOutcome outcome = filter_.update(z, &d2);
  r.quality.inertial_mahalanobis2 = d2;
  if (outcome == imu::UpdateOutcome::kRefused) {
    t.vision_ok = false;
    t.refusal = {Refusal::kInertialGate, d2, params_.inertial.gate_chi2};
  }
  r.quality.imu_fault = outcome == imu::UpdateOutcome::kImuFault;
}

}  // namespace seavio::odometry
