/// Odometry's refinement stage (paper III-C): the four-view motion refined over the RANSAC's
/// inliers, with the gyro's rotation as a prior, and once more without it for the inertial
/// filter.
#include <algorithm>

#include "core/odometry/odometry.hpp"

namespace seavio::odometry {
namespace {

/// Keyframe tracking: the rotation a gyro-bias error of covariance `Pbg_B` [body] turns over
/// the keyframe's span before this interval (this interval's is in the prediction), in the rig.
Eigen::Matrix3d keyframeBiasCovariance(const Eigen::Matrix3d& Pbg_B, const Eigen::Matrix3d& R_B_R0, double dt_s,
                                       double dt_ref_s) {
  const double span2 = std::max(0.0, dt_ref_s * dt_ref_s - dt_s * dt_s);
  return R_B_R0.transpose() * Pbg_B * R_B_R0 * span2;
}

}  // namespace

void Odometry::refineWithRotationPrior(FrameTrack& t) {
  const camera::RectifiedRig& rig = frontend_.rig();
  const geometry::RansacResult& ransac = work_.ransac;
  t.T_ref_curr = t.vision_ok ? ransac.T_prev_curr : t.reference.T_ref_curr_pred;
  t.rel_cov = t.vision_ok ? Matrix6d(ransac.covariance) : t.prediction.covariance;
  if (t.vision_ok && params_.use_rotation_prior) {
    // IMU-aided refinement: the gyro's rotation as a prior removes the pitch/surge ambiguity
    // of a flat floor (see motion_refinement.hpp).
    RotationPrior prior;
    prior.valid = t.prediction.have_imu;
    prior.R_prev_curr = t.reference.R_ref_curr_gyro;
    // Relative rotation noise only: the absolute attitude uncertainty carried in the start
    // covariance passes through the short propagation unchanged (F ~ I) and is removed.
    // Since a keyframe, the gyro's white noise adds up per interval, its bias error with time.
    prior.covariance = t.reference.gyro_covariance + t.prediction.covariance.topLeftCorner<3, 3>() +
                       keyframeBiasCovariance(filter_.covariance().block<3, 3>(imu::kEsBg, imu::kEsBg),
                                              rig.T_B_R0.rotation(), t.prediction.dt_s, t.reference.dt_s);
    const MotionRefinementResult refined = refineMotion(rig, work_.quads, ransac.inliers, t.T_ref_curr, prior,
                                                        params_.refinement, work_.refinement, &work_.sensitivity);
    if (refined.ok) {
      t.T_ref_curr = refined.T_prev_curr;
      t.rel_cov = refined.covariance;
      t.sensitivity_ok = true;
    }
  }
  // The inertial estimator's measurement is the four-view motion without the gyro prior: the
  // prior-refined one would feed the gyro back to the filter as if vision had seen it.
  if (t.vision_ok && t.prediction.have_imu) {
    t.vision_alone = refineMotion(rig, work_.quads, ransac.inliers, ransac.T_prev_curr, RotationPrior{},
                                  params_.refinement, work_.refinement);
    if (!t.vision_alone->ok) t.vision_alone.reset();
  }
  t.T_W_R0 = t.reference.T_W_ref * t.T_ref_curr;
}

}  // namespace seavio::odometry
