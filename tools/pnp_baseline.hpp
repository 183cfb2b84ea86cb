#pragma once
/// The comparison baseline: frame-to-frame stereo odometry with PnP-RANSAC
/// on the reference frame's 3D points and the current left image, no IMU: every frame is
/// matched exhaustively (no prediction), the pose is the chain of PnP motions. Not the
/// paper's method; kept to measure it. What a competent plain frame-to-frame VO does and
/// nothing more: Lowe's ratio test, stereo triangulation on rectified rows (the Frontend),
/// PnP-RANSAC with Levenberg-Marquardt refinement on the inliers, a plausibility gate on the
/// motion, and a constant-velocity step over a frame whose motion failed or was rejected.
#include <optional>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera/rectified_rig.hpp"
#include "core/common/types.hpp"
#include "core/odometry/frontend.hpp"

namespace seavio::tools {

struct PnpBaselineParams {
  double reprojection_px = 1.0;  ///< RANSAC and refinement inlier threshold [px]
  int iterations = 200;
  int min_inliers = 15;       ///< fewer inliers than this: the frame's motion is not trusted
  double threshold = 0.0;     ///< detector threshold, fixed (no count controller)
  float ratio = 0.8f;         ///< Lowe's ratio test on the inter-frame matches
  int refine_rounds = 2;      ///< LM refinement on the inliers, inliers re-selected after each
  /// Plausibility gate: a frame's step (translation and rotation angle) may exceed the
  /// previous step by at most this factor ...
  double max_step_ratio = 3.0;
  /// ... or the floors below times the frame interval, whichever is larger (a vehicle
  /// hovering or starting from rest, where 3x the previous step is nothing). No gate before
  /// the first step is known, nor right after the reference was given up: a sequence that
  /// starts in motion (KITTI: 1 m per frame) would otherwise never get going.
  double min_gate_speed_m_s = 1.0;
  double min_gate_rate_rad_s = 0.5;
  /// A failed frame is skipped: the next one is matched against the last good frame, up to
  /// this many frames back; older than that, the current frame (at its constant-velocity
  /// pose) becomes the reference.
  int max_reference_age = 3;
};

/// One PnP estimate: the motion mapping points of the previous R0 into the current R0.
struct PnpMotion {
  Eigen::Isometry3d T_curr_prev = Eigen::Isometry3d::Identity();
  int inliers = 0;
};

/// PnP-RANSAC (OpenCV, EPnP minimal samples) of the previous frame's 3D points `object_prev`
/// (in the previous R0) against their pixels `image_curr` in the current rectified left image,
/// then `refine_rounds` of Levenberg-Marquardt on the inliers, re-selecting the inliers with
/// the refined motion each time. nullopt if fewer than `min_inliers` remain or OpenCV fails.
std::optional<PnpMotion> solvePnpMotion(const std::vector<cv::Point3f>& object_prev,
                                        const std::vector<cv::Point2f>& image_curr, const camera::RectifiedRig& rig,
                                        const PnpBaselineParams& params);

class PnpBaseline {
 public:
  PnpBaseline(const odometry::Frontend& frontend, const PnpBaselineParams& params) : frontend_(frontend), params_(params) {}
  /// One stereo frame: front end, then track(). `now` times the stages (may be empty).
  OdometryResult process(const StereoFrame& frame, const NowNsFn& now = {});
  /// The frame's features in (as the Frontend gives them), its pose out. A frame whose motion
  /// is missing or implausible gets the previous step again, flagged kImuOnly (here: "no
  /// vision", there is no IMU in the baseline).
  OdometryResult track(odometry::FrameFeatures f, const NowNsFn& now = {});

 private:
  /// Whether the step `T_prev_curr` (R0 of the last output pose to the candidate) over `dt_s`
  /// passes the gate against the previous step.
  bool plausible(const Eigen::Isometry3d& T_prev_curr, double dt_s) const;

  const odometry::Frontend& frontend_;
  PnpBaselineParams params_;
  std::optional<odometry::FrameFeatures> reference_;  ///< the frame the next one is matched against
  Eigen::Isometry3d T_W_ref_ = Eigen::Isometry3d::Identity();  ///< its R0 pose
  int reference_age_ = 0;                                      ///< frames since it
  Eigen::Isometry3d T_W_R0_ = Eigen::Isometry3d::Identity();   ///< the last output's R0 pose
  Eigen::Isometry3d step_ = Eigen::Isometry3d::Identity();     ///< last step, T_prev_curr of R0
  bool step_known_ = false;  ///< step_ was measured since the start or the last re-reference
  int64_t last_t_ns_ = 0;
};

}  // namespace seavio::tools
