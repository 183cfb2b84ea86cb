#pragma once
/// Small SO(3)/SE(3) helpers on Eigen types (Debian has no Sophus). Tangent order is
/// (rotation, translation) everywhere in seavio.
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace seavio::se3 {

using Vector6d = Eigen::Matrix<double, 6, 1>;

inline Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// Rotation vector [rad] -> rotation matrix (Rodrigues), stable near zero.
inline Eigen::Matrix3d expSO3(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  if (theta < 1e-10) return Eigen::Matrix3d::Identity() + skew(w);
  return Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
}

/// Rotation matrix -> rotation vector [rad].
inline Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

/// Right Jacobian of SO(3), used to propagate IMU noise into the rotation error.
inline Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const Eigen::Matrix3d W = skew(w);
  if (theta < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * W;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() - (1 - std::cos(theta)) / t2 * W +
         (theta - std::sin(theta)) / (t2 * theta) * W * W;
}

/// Twist (rotation vector, translation) -> isometry; translation is taken as is
/// (the "SO(3) x R^3" retraction, simpler than the full SE(3) exp and enough for
/// small increments in optimisers).
inline Eigen::Isometry3d expSE3(const Vector6d& xi) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = expSO3(xi.head<3>());
  T.translation() = xi.tail<3>();
  return T;
}

/// Inverse of expSE3.
inline Vector6d logSE3(const Eigen::Isometry3d& T) {
  Vector6d xi;
  xi.head<3>() = logSO3(T.rotation());
  xi.tail<3>() = T.translation();
  return xi;
}

/// Isometry from a row-major 4x4 (EuRoC `T_BS.data`, Kalibr `T_cam_imu`).
inline Eigen::Isometry3d fromRowMajor4x4(const double* d) {
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = d[4 * r + c];
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Re-orthonormalise: calibration files carry 6-8 digits only.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.topLeftCorner<3, 3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

/// Rotation angle of an isometry [rad].
inline double angle(const Eigen::Isometry3d& T) { return Eigen::AngleAxisd(T.rotation()).angle(); }

/// Pose built from translation and quaternion (w, x, y, z order in the arguments).
inline Eigen::Isometry3d fromTQ(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

}  // namespace seavio::se3
