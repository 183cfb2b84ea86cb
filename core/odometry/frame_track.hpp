#pragma once
/// What the stages of Odometry::track hand each other for one frame: the prediction (III-A),
/// the reference the frame is tracked against and the visual motion found against it (III-C),
/// the registration's effect (III-D/E) and the verdict on the frame.
#include <optional>

#include <Eigen/Geometry>

#include "core/common/covariance.hpp"
#include "core/common/refusal.hpp"
#include "core/imu/error_state_filter.hpp"
#include "core/matching/temporal_matcher.hpp"
#include "core/odometry/global_refiner.hpp"
#include "core/odometry/motion_refinement.hpp"

namespace seavio::odometry {

/// III-A: the motion since the previous frame before vision has seen it.
struct MotionPrediction {
  double dt_s = 0;         ///< since the previous frame
  bool have_imu = false;   ///< from the inertial filter; else constant velocity
  Eigen::Isometry3d T_prev_curr_B = Eigen::Isometry3d::Identity();  ///< the filter's, body (have_imu only)
  Eigen::Isometry3d T_prev_curr = Eigen::Isometry3d::Identity();    ///< rectified left camera
  Matrix6d covariance = Matrix6d::Zero();                          ///< of T_prev_curr
};

/// The frame the current one is matched against: the keyframe, or the previous frame. In the
/// stages a name with "ref" means this frame.
struct TrackingReference {
  const matching::StereoFeatures* features = nullptr;
  Eigen::Isometry3d T_W_ref = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_ref_curr_pred = Eigen::Isometry3d::Identity();  ///< the prediction against it
  Eigen::Matrix3d R_ref_curr_gyro = Eigen::Matrix3d::Identity();      ///< the gyro alone since it
  Eigen::Matrix3d gyro_covariance = Eigen::Matrix3d::Zero();          ///< its noise before this interval
  double dt_s = 0;                                                    ///< since it
  bool on_keyframe = false;
};

struct FrameTrack {
  MotionPrediction prediction;
  TrackingReference reference;
  bool keyframe_usable = false;  ///< keyframe tracking on and a keyframe held
  /// The feature controller's inlier target reads frames tracked against the previous frame
  /// only: their overlap is the one the frame rate gives. Against an ageing keyframe the
  /// inliers fall by design until a new keyframe is made.
  bool reference_is_previous = true;
  /// The reference reaches the previous frame through measured poses (not a coasted frame).
  bool reference_measured = true;

  bool vision_ok = false;
  bool rescued = false;  ///< the RANSAC result came from the rescue RANSAC (its threshold)
  RefusalFigures refusal;

  Eigen::Isometry3d T_ref_curr = Eigen::Isometry3d::Identity();  ///< the motion against the reference
  Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();      ///< the frame's rig pose as it stands
  Eigen::Isometry3d T_W_B = Eigen::Isometry3d::Identity();
  Matrix6d rel_cov = Matrix6d::Zero();  ///< the motion's covariance against the reference
  bool sensitivity_ok = false;          ///< the refinement's pixel sensitivity belongs to rel_cov
  /// The four-view motion without the gyro prior: the inertial filter's measurement.
  std::optional<MotionRefinementResult> vision_alone;

  /// Global mode: how far the map moved the frame off its odometry. A correction is not motion,
  /// so it stays out of the speed check and the velocity.
  Eigen::Vector3d map_shift_W = Eigen::Vector3d::Zero();
  std::optional<Eigen::Isometry3d> map_delta_W;     ///< the inline map correction, a delta in W
  std::optional<GlobalCorrection> inline_revisit;  ///< the re-observation's covariance update
};

}  // namespace seavio::odometry
