#pragma once
/// Pose hygiene shared by the odometry and the global step: no NaN ever leaves core, and a
/// rotation stays a rotation however many poses are chained.
#include <Eigen/Geometry>

namespace seavio::odometry {

inline bool finitePose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

/// `T` with its linear part projected back onto SO(3). Isometry3d::inverse() and rotation()
/// take the linear part as orthonormal; a pose composed frame after frame and fed back through
/// the IMU prediction (pose^-1 * predicted pose) otherwise doubles its round-off every frame,
/// until the world rotation carries a ~0.5 % scale that shortens every published step.
inline Eigen::Isometry3d orthonormalized(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = T;
  out.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  return out;
}

}  // namespace seavio::odometry
