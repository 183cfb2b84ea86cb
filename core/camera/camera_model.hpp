#pragma once
/// Pinhole camera with radial-tangential or equidistant (fisheye) distortion, as in
/// EuRoC `sensor.yaml` and Kalibr.
#include <array>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace seavio::camera {

enum class DistortionModel { kNone, kRadialTangential, kEquidistant };

struct CameraIntrinsics {
  int width = 0, height = 0;          ///< [px]
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< [px]
  DistortionModel model = DistortionModel::kNone;
  /// radial-tangential: k1 k2 p1 p2; equidistant: k1 k2 k3 k4.
  std::array<double, 4> distortion{0, 0, 0, 0};

  /// Point in the camera frame (z forward) -> distorted pixel.
  Eigen::Vector2d project(const Eigen::Vector3d& p_C) const;
  /// Distorted pixel -> normalised image coordinates (x/z, y/z), iterative undistortion.
  Eigen::Vector2d undistortToNormalized(const Eigen::Vector2d& uv) const;
  cv::Mat K() const;  ///< 3x3 CV_64F
  cv::Mat D() const;  ///< 1x4 CV_64F
};

/// Raw (unrectified) stereo calibration, camera poses in the body (IMU) frame.
struct StereoCalibration {
  CameraIntrinsics cam0, cam1;
  Eigen::Isometry3d T_B_C0 = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_B_C1 = Eigen::Isometry3d::Identity();
};

/// EuRoC's and Kalibr's names (kDistortionModelNames); nullopt for another.
std::optional<DistortionModel> parseDistortionModel(const std::string& name);
inline constexpr const char* kDistortionModelNames = "radial-tangential, radtan, equidistant or none";
std::string toString(DistortionModel m);

}  // namespace seavio::camera
