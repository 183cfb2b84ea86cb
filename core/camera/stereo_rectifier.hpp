#pragma once
/// Undistortion + rectification maps computed once from the calibration (OpenCV
/// stereoRectify + initUndistortRectifyMap), paper section III step 1.
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "core/camera/camera_model.hpp"
#include "core/camera/rectified_rig.hpp"

namespace seavio::camera {

class StereoRectifier {
 public:
  /// Builds the maps; `alpha` as in cv::stereoRectify (0 = only valid pixels); for
  /// equidistant lenses it is cv::fisheye::stereoRectify's `balance` (0 = no black border).
  /// Returns nullopt and sets `error` if the calibration is unusable.
  static std::optional<StereoRectifier> create(const StereoCalibration& calib, std::string* error,
                                               double alpha = 0.0);

  const RectifiedRig& rig() const { return rig_; }
  const StereoCalibration& calibration() const { return calib_; }

  /// Remaps a raw pair into the rectified pair (bilinear; remapBilinear, the bytes of
  /// cv::remap). Output buffers are reused: no allocation once they have the image size.
  void rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left_rect,
               cv::Mat& right_rect) const;
  /// Camera `cam`'s (0/1) fixed-point remap tables (cv::convertMaps' CV_16SC2 source pixel
  /// and CV_16UC1 fraction index), for comparison with cv::remap in benchmarks.
  const cv::Mat& remapPixels(int cam) const { return cam == 0 ? map0a_ : map1a_; }
  const cv::Mat& remapFractions(int cam) const { return cam == 0 ? map0b_ : map1b_; }
  /// One image of camera `cam` (0 left, 1 right): `rectify` is this for both. Lets the two
  /// sides run on different threads.
  void rectifyOne(int cam, const cv::Mat& raw, cv::Mat& rect) const;
  /// Raw distorted pixel of camera `cam` (0/1) -> rectified pixel.
  Eigen::Vector2d rectifyPoint(int cam, const Eigen::Vector2d& uv_raw) const;

  Eigen::Matrix3d R_R0_C0() const { return R_R0_C0_; }  ///< raw left -> rectified left rotation
  Eigen::Matrix3d R_R1_C1() const { return R_R1_C1_; }

 private:
  StereoCalibration calib_;
  RectifiedRig rig_;
  Eigen::Matrix3d R_R0_C0_ = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R_R1_C1_ = Eigen::Matrix3d::Identity();
  cv::Mat R0_, R1_;  ///< OpenCV rectification rotations (R_R0_C0, R_R1_C1)
  cv::Mat P0_, P1_;  ///< rectified projection matrices, 3x4
  cv::Mat map0a_, map0b_, map1a_, map1b_;  ///< fixed-point remap tables (CV_16SC2 + CV_16UC1)
};

}  // namespace seavio::camera
