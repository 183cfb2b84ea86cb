#include "core/odometry/increment_covariance.hpp"

#include "core/common/capacity.hpp"
#include "core/common/se3.hpp"
#include "core/imu/error_state_filter.hpp"

namespace seavio::odometry {

Matrix6d bodyCovarianceSincePrevious(const Matrix6d& covariance_ref, const Eigen::Isometry3d& T_prev_ref,
                                     const Eigen::Isometry3d& T_prev_curr, const Eigen::Isometry3d& T_B_R0) {
  // Left perturbation in the reference camera -> in the previous camera: the adjoint of T_prev_ref.
  Matrix6d Ad = Matrix6d::Zero();
  Ad.topLeftCorner<3, 3>() = T_prev_ref.rotation();
  Ad.bottomRightCorner<3, 3>() = T_prev_ref.rotation();
  Ad.bottomLeftCorner<3, 3>() = se3::skew(T_prev_ref.translation()) * T_prev_ref.rotation();
  return imu::cameraToBodyMotionCovariance(Ad * covariance_ref * Ad.transpose(), T_prev_curr, T_B_R0);
}

void KeyframeIncrementCovariance::record(uint64_t keyframe_id, int64_t t_ns, const ReferenceSensitivity& sensitivity,
                                         std::span<const uint32_t> reference_of_match, std::size_t reference_points) {
  recorded_ = true;
  keyframe_id_ = keyframe_id;
  t_ns_ = t_ns;
  covariance_ = sensitivity.covariance;
  prior_gain_ = sensitivity.prior_gain;
  prior_covariance_ = sensitivity.prior_covariance;
  resizeWithHeadroom(gain_, reference_points);
  used_.assign(reference_points, 0);
  for (std::size_t j = 0; j < sensitivity.match.size() && j < sensitivity.gain.size(); ++j) {
    const uint32_t m = sensitivity.match[j];
    if (m >= reference_of_match.size() || reference_of_match[m] >= reference_points) continue;
    gain_[reference_of_match[m]] = sensitivity.gain[j];
    used_[reference_of_match[m]] = 1;
  }
}

std::optional<Matrix6d> KeyframeIncrementCovariance::increment(
    uint64_t keyframe_id, int64_t previous_t_ns, const ReferenceSensitivity& sensitivity,
    std::span<const uint32_t> reference_of_match) const {
  if (!recorded_ || keyframe_id != keyframe_id_ || previous_t_ns != t_ns_) return std::nullopt;
  // X = Cov(d_k, d_{k-1}): the keyframe points both used, and the prior. The later prior
  // extends the earlier one by this interval's independent gyro noise, so the earlier one's
  // error is the part they share.
  Matrix6d X = sensitivity.prior_gain * prior_covariance_ * prior_gain_.transpose();
  for (std::size_t j = 0; j < sensitivity.match.size() && j < sensitivity.gain.size(); ++j) {
    const uint32_t m = sensitivity.match[j];
    if (m >= reference_of_match.size()) continue;
    const uint32_t p = reference_of_match[m];
    if (p < used_.size() && used_[p]) X += sensitivity.gain[j] * gain_[p].transpose();
  }
  const Matrix6d C = sensitivity.covariance + covariance_ - X - X.transpose();
  return Matrix6d(0.5 * (C + C.transpose()));
}

}  // namespace seavio::odometry
