/// Odometry's state update: the frame's pose, velocity and covariance from vision when it was
/// accepted; else coasting on the inertial filter's propagation, or, with no IMU, on the
/// constant-velocity prediction. The published pose is always finite.
#include "core/common/covariance.hpp"
#include "core/odometry/chain_covariance.hpp"
#include "core/odometry/odometry.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {

void Odometry::updatePose(int64_t t_ns, FrameTrack& t, OdometryResult& r) {
  if (t.vision_ok) {
    takeVisualPose(t);
    r.source = PoseSource::kVision;
  } else {
    coast(t);
    r.source = PoseSource::kImuOnly;
    r.coasting = t.prediction.have_imu ? CoastingCorrection::kInertial : CoastingCorrection::kNoImu;
    r.refusal = t.refusal;
  }
  if (t.prediction.have_imu) {
    const NavState f = filter_.state();
    state_.gyro_bias_rad_s = f.gyro_bias_rad_s;
    state_.accel_bias_m_s2 = f.accel_bias_m_s2;
    r.gyro_bias_sigma_rad_s = filter_.covariance().block<3, 3>(imu::kEsBg, imu::kEsBg).diagonal().cwiseSqrt();
    r.accel_bias_sigma_m_s2 = filter_.covariance().block<3, 3>(imu::kEsBa, imu::kEsBa).diagonal().cwiseSqrt();
    // A visual fix anchors the filter's position; coasting frames keep what accrues since.
    filter_.clonePose(r.source == PoseSource::kVision);
    if (r.source == PoseSource::kVision) fix_filter_covariance_ = filter_.poseCovarianceW();
  }
  state_.t_ns = t_ns;
  if (!finitePose(state_.T_W_B) || !state_.v_W.allFinite()) {
    // Never let a NaN leave core: hold the last finite state.
    state_.T_W_B = previous_->T_W_R0 * frontend_.rig().T_B_R0.inverse();
    state_.v_W.setZero();
    t.T_W_R0 = previous_->T_W_R0;
    r.source = PoseSource::kImuOnly;
    r.coasting = CoastingCorrection::kHeld;
    r.refusal = {Refusal::kNonFinite, 0, 0};
    if (filter_.started()) filter_stale_ = true;  // restarts from the held state
  }
}

void Odometry::takeVisualPose(const FrameTrack& t) {
  const TrackingReference& ref = t.reference;
  // The velocity: the filter's, turned from its world into the chain's (they share the
  // start-up frame and part only by the chain's rotation drift); without an IMU the visual
  // step's. A map correction is not motion: it only turns the velocity with the frame.
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  if (t.prediction.have_imu) {
    const NavState f = filter_.state();
    v = t.T_W_B.rotation() * f.T_W_B.rotation().transpose() * f.v_W;
  } else if (t.prediction.dt_s > 1e-6) {
    v = (t.T_W_B.translation() - t.map_shift_W - state_.T_W_B.translation()) / t.prediction.dt_s;
  }
  if (t.map_delta_W) v = t.map_delta_W->linear() * v;
  state_.T_W_B = t.T_W_B;
  state_.v_W = v;
  if (ref.on_keyframe) pose_covariance_ = keyframe_->pose_covariance;
  // The reference's rotation error turns this step, and the heading random-walks with the
  // gyro-bias error since the reference (chain_covariance.hpp: the global search's sigma).
  composeChainCovariance(pose_covariance_, t.rel_cov, ref.T_W_ref.rotation(),
                         t.T_W_R0.translation() - t.map_shift_W - ref.T_W_ref.translation(),
                         headingVariance(params_.heading_bias_error_rad_s, params_.heading_bias_time_constant_s,
                                         ref.dt_s));
  // The keyframe this frame was tracked against moves with it (the same delta in W as
  // applyGlobalCorrection composes), so the frames tracked against it next keep the map's
  // correction instead of falling back to where the odometry alone put them; its
  // uncertainty shrinks with the frame's when the map bounded the drift (III-D).
  if (ref.on_keyframe && t.map_delta_W) keyframe_->T_W_R0 = orthonormalized(*t.map_delta_W * keyframe_->T_W_R0);
  if (t.inline_revisit) {
    t.inline_revisit->shrink(pose_covariance_);
    if (ref.on_keyframe) t.inline_revisit->shrink(keyframe_->pose_covariance);
  }
  fix_pose_covariance_ = pose_covariance_;
}

void Odometry::coast(FrameTrack& t) {
  const PreviousFrame& prev = *previous_;
  const Eigen::Isometry3d& T_B_R0 = frontend_.rig().T_B_R0;
  if (t.prediction.have_imu) {
    // Vision refused: coast on the filter's propagation from the previous frame, flagged. The
    // covariance is the last fix's plus what the filter's grew by since: its velocity, tilt and
    // bias errors with their correlations make dead-reckoning error grow with time squared.
    t.T_W_B = orthonormalized(prev.T_W_R0 * T_B_R0.inverse() * t.prediction.T_prev_curr_B);
    t.T_W_R0 = t.T_W_B * T_B_R0;
    const NavState f = filter_.state();
    state_.T_W_B = t.T_W_B;
    state_.v_W = t.T_W_B.rotation() * f.T_W_B.rotation().transpose() * f.v_W;
    pose_covariance_ = fix_pose_covariance_ + positivePart(filter_.poseCovarianceW() - fix_filter_covariance_);
    return;
  }
  // No IMU: the constant-velocity prediction, its loose covariance composed onto the chain's.
  t.T_W_R0 = orthonormalized(prev.T_W_R0 * t.prediction.T_prev_curr);
  t.T_W_B = orthonormalized(t.T_W_R0 * T_B_R0.inverse());
  state_.T_W_B = t.T_W_B;
  composeChainCovariance(pose_covariance_, t.prediction.covariance, prev.T_W_R0.rotation(),
                         t.T_W_R0.translation() - prev.T_W_R0.translation(), 0.0);
}

}  // namespace seavio::odometry
