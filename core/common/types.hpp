#pragma once
/// Value types that flow through the pipeline (ARCHITECTURE.md, "Core types").
#include <cstdint>
#include <functional>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/common/refusal.hpp"

namespace seavio {

/// One stereo pair as it leaves the cameras: 8-bit grey, unrectified.
struct StereoFrame {
  int64_t t_ns = 0;   ///< capture time on the process' monotonic clock [ns]
  uint64_t seq = 0;   ///< sequence number from the source (gaps = dropped frames)
  cv::Mat left;       ///< CV_8UC1, camera 0
  cv::Mat right;      ///< CV_8UC1, camera 1
};

/// One IMU measurement in the body (IMU) frame B.
struct ImuSample {
  int64_t t_ns = 0;                                    ///< [ns]
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();  ///< angular rate [rad/s]
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();  ///< specific force [m/s^2]
};

/// Full navigation state of the body in the gravity-aligned world frame W (z up).
struct NavState {
  int64_t t_ns = 0;
  Eigen::Isometry3d T_W_B = Eigen::Isometry3d::Identity();  ///< body -> world
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();            ///< velocity in W [m/s]
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();
};

/// Where a published pose came from.
enum class PoseSource : uint8_t {
  kInit = 0,     ///< first frame: the world origin
  kVision = 1,   ///< visual estimate (tensor + ICP)
  kImuOnly = 2,  ///< vision failed this frame: IMU dead reckoning, flagged
};

/// What an IMU-only frame coasted on.
enum class CoastingCorrection : uint8_t {
  kNone = 0,      ///< not coasted: a visual (or the first) frame
  kInertial = 1,  ///< the inertial filter's propagation (core/imu/error_state_filter.hpp)
  kNoImu = 2,     ///< no IMU: the constant-velocity prediction
  kHeld = 3,      ///< the estimate was not finite: the last finite pose held
};

/// Per-stage wall time of one frame [ms] (the paper's Table II columns and more).
struct StageTimes {
  double rectify_ms = 0;
  double features_ms = 0;
  double stereo_ms = 0;
  double temporal_ms = 0;
  double tensor_ms = 0;
  /// The part of tensor_ms spent on patch alignment (patch refinement, guided tracks and the
  /// RANSAC reselection that judges them); the rest is RANSAC and the motion refinements.
  double patch_ms = 0;
  double icp_ms = 0;
  double total_ms = 0;
};

/// Quality figures of one frame.
struct Quality {
  int features_left = 0;
  int features_right = 0;
  int stereo_matches = 0;    ///< stereo points, completed ones included
  int stereo_completed = 0;  ///< of those, added by stereo completion (not descriptor matches)
  int temporal_matches = 0;
  int ransac_inliers = 0;
  int guided_tracks = 0;  ///< reference points found by patch alignment, not descriptors (before RANSAC's verdict)
  int icp_iterations = 0;
  int icp_inliers = 0;
  double icp_rms_m = 0;
  int model_points = 0;
  double detector_threshold = 0;
  /// Global mode: the map moved this pose (re-observation of an old keyframe or map ICP,
  /// paper III-D/E); false for a frame-to-frame pose.
  bool map_refined = false;
  /// The visual motion's squared Mahalanobis distance to the inertial prediction (0: no update).
  double inertial_mahalanobis2 = 0;
  /// Vision and the IMU disagreed for long enough that the IMU was judged at fault this frame
  /// (ErrorStateParams::imu_fault_refusals): its inertial states were re-opened.
  bool imu_fault = false;
};

/// What `Odometry::process` returns for each stereo frame.
struct OdometryResult {
  int64_t t_ns = 0;
  uint64_t seq = 0;
  Eigen::Isometry3d T_W_B = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  /// Pose covariance, tangent order (rotation [rad], translation [m]) in W.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
  PoseSource source = PoseSource::kInit;
  /// kImuOnly frames: how the coasting was corrected; kNone otherwise.
  CoastingCorrection coasting = CoastingCorrection::kNone;
  /// kImuOnly frames: the check that refused the visual estimate and by how much.
  RefusalFigures refusal;
  /// The inertial filter's 1-sigma of its gyro [rad/s] and accelerometer [m/s^2] bias per body
  /// axis after this frame (the square roots of its covariance's diagonal), so a consistency
  /// check can hold the biases against the truth; zero when the frame had no IMU.
  Eigen::Vector3d gyro_bias_sigma_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_sigma_m_s2 = Eigen::Vector3d::Zero();
  /// The covariance the estimate claims for the published pose's increment since the previous
  /// frame, T_W_B(prev)^-1 T_W_B: the visual motion's (the prior-refined one the pose is
  /// chained from, with the pixel noise its residuals show), in the filter's RelativeMotion
  /// convention: rotation as a right perturbation in the current body [rad], translation in the
  /// previous body [m]. Tracked against a keyframe the previous frame was also placed from, the
  /// error the two frames share (the keyframe's pixels, the gyro prior since the keyframe) is
  /// taken out (increment_covariance.hpp). Zero when the increment is not a visual one: the first
  /// frame, a coasted frame, a frame tracked against a keyframe across a coasted one, and a frame
  /// the global map moved.
  Eigen::Matrix<double, 6, 6> increment_covariance = Eigen::Matrix<double, 6, 6>::Zero();
  Quality quality;
  StageTimes times;
};

/// Monotonic time source injected into core so that core itself owns no clock.
/// Returns nanoseconds; the default (null) means "don't time".
using NowNsFn = std::function<int64_t()>;

}  // namespace seavio
