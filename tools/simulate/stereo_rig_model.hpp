#pragma once
/// The simulated stereo rig: intrinsics, radial-tangential distortion, extrinsics in the body
/// frame, and exact projection / undistortion used by the renderer and the tests.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera/camera_model.hpp"
#include "tools/simulate/sim_config.hpp"

namespace seavio::simulate {

class StereoRigModel {
 public:
  explicit StereoRigModel(const RigConfig& config);

  /// Calibration as written to sensor.yaml (EuRoC T_BS = T_B_C).
  const camera::StereoCalibration& calibration() const { return calib_; }
  const camera::CameraIntrinsics& intrinsics(int cam) const { return cam == 0 ? calib_.cam0 : calib_.cam1; }
  const Eigen::Isometry3d& T_B_C(int cam) const { return cam == 0 ? calib_.T_B_C0 : calib_.T_B_C1; }

  /// Point in camera `cam` (z forward) -> distorted pixel; nullopt-free: caller checks z > 0.
  Eigen::Vector2d project(int cam, const Eigen::Vector3d& p_C) const;
  /// Normalised undistorted coordinates -> distorted pixel.
  Eigen::Vector2d distort(int cam, const Eigen::Vector2d& xy) const;
  /// Distorted pixel -> normalised coordinates (x/z, y/z), Gauss-Newton to 1e-10 px.
  Eigen::Vector2d undistort(int cam, const Eigen::Vector2d& uv) const;

 private:
  camera::StereoCalibration calib_;
};

}  // namespace seavio::simulate
