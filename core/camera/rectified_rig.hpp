#pragma once
/// The ideal stereo rig after rectification: both cameras share intrinsics and
/// orientation, the right one sits `baseline_m` along +x of the left (R0).
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace seavio::camera {

struct RectifiedRig {
  int width = 0;             ///< [px]
  int height = 0;            ///< [px]
  double f_px = 0;           ///< focal length, same in x and y [px]
  double cx = 0, cy = 0;     ///< principal point [px]
  double baseline_m = 0;     ///< distance R0 -> R1 along +x of R0 [m]
  Eigen::Isometry3d T_B_R0 = Eigen::Isometry3d::Identity();  ///< rectified left camera -> body

  /// Project a point in R0 into the left (cam = 0) or right (cam = 1) rectified image.
  Eigen::Vector2d project(const Eigen::Vector3d& p_R0, int cam = 0) const {
    const double x = p_R0.x() - (cam == 1 ? baseline_m : 0.0);
    return {f_px * x / p_R0.z() + cx, f_px * p_R0.y() / p_R0.z() + cy};
  }
  /// Triangulate from a rectified left pixel and disparity d = u_left - u_right [px].
  Eigen::Vector3d triangulate(const Eigen::Vector2d& uv_left, double disparity_px) const {
    const double z = f_px * baseline_m / disparity_px;
    return {(uv_left.x() - cx) * z / f_px, (uv_left.y() - cy) * z / f_px, z};
  }
  /// Disparity [px] of a point at depth z [m].
  double disparityAt(double z_m) const { return f_px * baseline_m / z_m; }
};

}  // namespace seavio::camera
