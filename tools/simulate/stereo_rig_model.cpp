#include "tools/simulate/stereo_rig_model.hpp"

#include <cmath>
#include <numbers>

namespace seavio::simulate {

StereoRigModel::StereoRigModel(const RigConfig& c) {
  const double f = 0.5 * c.width / std::tan(0.5 * c.hfov_deg * std::numbers::pi / 180.0);
  auto make = [&](double fx, const Eigen::Vector2d& off, const std::array<double, 4>& d) {
    camera::CameraIntrinsics k;
    k.width = c.width;
    k.height = c.height;
    k.fx = fx;
    k.fy = fx * 1.0005;  // slightly non-square pixels, as calibrations report
    k.cx = 0.5 * (c.width - 1) + off.x();
    k.cy = 0.5 * (c.height - 1) + off.y();
    k.model = camera::DistortionModel::kRadialTangential;
    k.distortion = d;
    return k;
  };
  calib_.cam0 = make(f, c.principal_offset0_px, c.distortion0);
  calib_.cam1 = make(f * c.focal_ratio1, c.principal_offset1_px, c.distortion1);
  // Looking down: camera x = -body y (right), y = -body x (image top is forward), z = -body z.
  Eigen::Matrix3d R_B_Cdown;
  R_B_Cdown << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  const double tilt = c.tilt_deg * std::numbers::pi / 180.0;
  // Rotation about body y by -tilt swings the optical axis from -z towards +x (forward).
  Eigen::Matrix3d R_B_C0 = Eigen::AngleAxisd(-tilt, Eigen::Vector3d::UnitY()).toRotationMatrix() * R_B_Cdown;
  if (!c.mount_error_deg.isZero()) {
    const Eigen::Vector3d e = c.mount_error_deg * std::numbers::pi / 180.0;
    R_B_C0 = (Eigen::AngleAxisd(e.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(e.y(), Eigen::Vector3d::UnitY()) *
              Eigen::AngleAxisd(e.x(), Eigen::Vector3d::UnitX()))
                 .toRotationMatrix() *
             R_B_C0;
  }
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, 0.5, 0.8).normalized();
  const Eigen::Matrix3d R_C0_C1 =
      Eigen::AngleAxisd(c.relative_rotation_deg * std::numbers::pi / 180.0, axis).toRotationMatrix();
  const Eigen::Vector3d x_C0_B = R_B_C0.col(0);  // camera 1 sits along +x of camera 0
  calib_.T_B_C0.linear() = R_B_C0;
  calib_.T_B_C0.translation() = c.lever_arm_m - 0.5 * c.baseline_m * x_C0_B;
  calib_.T_B_C1.linear() = R_B_C0 * R_C0_C1;
  calib_.T_B_C1.translation() = c.lever_arm_m + 0.5 * c.baseline_m * x_C0_B;
}

Eigen::Vector2d StereoRigModel::distort(int cam, const Eigen::Vector2d& xy) const {
  const auto& k = intrinsics(cam);
  const double x = xy.x(), y = xy.y(), r2 = x * x + y * y;
  const auto& d = k.distortion;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  return {k.fx * xd + k.cx, k.fy * yd + k.cy};
}

Eigen::Vector2d StereoRigModel::project(int cam, const Eigen::Vector3d& p_C) const {
  return distort(cam, p_C.head<2>() / p_C.z());
}

Eigen::Vector2d StereoRigModel::undistort(int cam, const Eigen::Vector2d& uv) const {
  const auto& k = intrinsics(cam);
  Eigen::Vector2d xy((uv.x() - k.cx) / k.fx, (uv.y() - k.cy) / k.fy);
  for (int it = 0; it < 30; ++it) {
    const Eigen::Vector2d r = distort(cam, xy) - uv;
    if (r.norm() < 1e-10) break;  // [px]
    Eigen::Matrix2d J;
    const double h = 1e-7;
    J.col(0) = (distort(cam, xy + Eigen::Vector2d(h, 0)) - distort(cam, xy - Eigen::Vector2d(h, 0))) / (2 * h);
    J.col(1) = (distort(cam, xy + Eigen::Vector2d(0, h)) - distort(cam, xy - Eigen::Vector2d(0, h))) / (2 * h);
    xy -= J.inverse() * r;
  }
  return xy;
}

}  // namespace seavio::simulate
