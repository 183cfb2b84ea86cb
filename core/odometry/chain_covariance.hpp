#pragma once
/// The absolute pose covariance of the odometry chain: what the global step sizes its
/// re-observation search and gate with (paper III-D: the map bounds the drift, so it must know
/// how far the drift can have gone).
///
/// Two terms a plain composition drops, which on the full 1 Hz paper survey leave the claimed
/// position sigma 50-100x below the real error (0.11 m against 9.4 m at the first revisit):
/// - The reference pose's rotation error turns every later step: composing
///   p = p_ref + R_ref t with R_ref off by dtheta moves p by dtheta x (p - p_ref). Without
///   that cross term a heading error never became a position error.
/// - The heading is held by the gyro alone (vision's relative rotation is refined with the
///   gyro as its prior; gravity holds only the tilt), so it random-walks with the error of
///   the heading part of the gyro-bias estimate, correlated over the estimator's time
///   constant: a Gauss-Markov bias error of sigma_b and time constant tau integrates to a
///   heading variance growing by 2 tau sigma_b^2 per second.
#include <algorithm>

#include <Eigen/Core>

#include "core/common/covariance.hpp"

namespace seavio::odometry {

/// Heading variance [rad^2] gained over `dt_s` from a gyro-bias estimate whose heading part
/// is off by `heading_bias_error_rad_s` (1 sigma), correlated over `bias_time_constant_s`.
inline double headingVariance(double heading_bias_error_rad_s, double bias_time_constant_s, double dt_s) {
  if (dt_s <= 0 || bias_time_constant_s <= 0) return 0.0;
  return 2.0 * bias_time_constant_s * heading_bias_error_rad_s * heading_bias_error_rad_s * dt_s;
}

/// Composes the absolute covariance of a reference pose with a relative motion measured from
/// it: `P` (tangent order rotation [rad], translation [m], both in W) is the reference's on
/// entry and the current pose's on return.
/// @param rel_cov the relative motion's covariance in the reference frame
/// @param R_W_ref the reference's attitude
/// @param d_W the step p_current - p_reference in W [m]
/// @param heading_variance_rad2 heading (about W's z, gravity) variance gained over the step
inline void composeChainCovariance(Matrix6d& P, const Matrix6d& rel_cov,
                                   const Eigen::Matrix3d& R_W_ref, const Eigen::Vector3d& d_W,
                                   double heading_variance_rad2) {
  // Left perturbation of the reference: R = Exp(dtheta) R_ref, p = p_ref + dp. Then the
  // current position moves by dp + dtheta x d = dp - [d]x dtheta.
  Matrix6d A = Matrix6d::Identity();
  Eigen::Matrix3d d_x;
  d_x << 0, -d_W.z(), d_W.y(), d_W.z(), 0, -d_W.x(), -d_W.y(), d_W.x(), 0;
  A.bottomLeftCorner<3, 3>() = -d_x;
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = R_W_ref;
  J.bottomRightCorner<3, 3>() = R_W_ref;
  Matrix6d next = A * P * A.transpose() + J * rel_cov * J.transpose();
  // The heading gained during the step turns the step itself by half of it on average; its
  // variance enters the rotation and, through the same lever, the position.
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  g(2) = 1.0;
  g.tail<3>() = -0.5 * d_x.col(2);
  next += std::max(heading_variance_rad2, 0.0) * g * g.transpose();
  P = 0.5 * (next + next.transpose());
}

}  // namespace seavio::odometry
