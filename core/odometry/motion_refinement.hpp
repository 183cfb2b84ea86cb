#pragma once
/// Final IMU-aided refinement of the inter-frame motion. A downward-looking rig over a nearly
/// flat floor cannot tell a small pitch from a small forward translation (both shift the image
/// almost uniformly), so the four-view reprojection alone leaves that direction soft. The
/// gyro, integrated over one frame interval, knows the rotation to a few thousandths of a
/// degree; as a prior it pins the rotation and lets the matches determine the translation.
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera/rectified_rig.hpp"
#include "core/geometry/quadrifocal_ransac.hpp"

namespace seavio::odometry {

struct RotationPrior {
  bool valid = false;
  Eigen::Matrix3d R_prev_curr = Eigen::Matrix3d::Identity();  ///< rectified left cameras
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();   ///< [rad^2], in the previous camera
};

struct MotionRefinementParams {
  int iterations = 8;
  double pixel_sigma_px = 0.25;  ///< feature localisation noise [px]
  double huber_px = 1.0;         ///< robust kernel width [px]
  double min_rotation_sigma_rad = 2e-5;  ///< floor on the prior's sigma [rad]
  /// The other three pixels of each match were aligned against a template cut around its
  /// reference-left pixel (patch refinement): the sensitivity's noise model (below).
  bool template_aligned = false;
};

struct MotionRefinementResult {
  bool ok = false;
  Eigen::Isometry3d T_prev_curr = Eigen::Isometry3d::Identity();
  /// Covariance of the left perturbation (rotation [rad], translation [m]) in the previous camera.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
  double rms_px = 0;
};

/// How the refined motion moves, to first order, with the noise of what a second motion against
/// the same reference shares with it: the reference pair's pixels and the rotation prior (the
/// gyro since the reference). Two frames tracked against one keyframe share those errors, and
/// their increment sheds them (increment_covariance.hpp).
/// All of it with the pixel noise the residuals show (the a posteriori variance of unit weight,
/// `variance_factor` times the model's pixel_sigma_px squared) rather than the model's: patch
/// alignment localises a point in the other three images relative to its reference-left
/// template, so its pixels err far less, and less independently, than the detector's sigma.
/// With `template_aligned` the noise is modelled as that alignment makes it: the
/// reference-left pixel is the template's origin, and an error of it is one the other three
/// follow (a shift of the point along the floor, which the point absorbs): it carries no
/// noise of its own. The reference-right pixel and the two current ones carry the
/// alignment's, independent between them (each from its own image), the reference-right one
/// shared by every frame tracked against that reference. The a posteriori variance counts
/// the residual degrees of freedom under that model, so it is the alignment's variance:
/// counting the reference-left pixel's share of the degrees of freedom as noise would put it
/// a quarter low, and the claim that much too tight.
struct ReferenceSensitivity {
  double variance_factor = 1;  ///< the noisy pixels' variance (from the residuals) / sigma^2
  /// The motion's covariance under that noise (the result's `covariance` keeps the model's).
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  std::vector<uint32_t> match;  ///< the index into `matches` of each entry of `gain`
  /// d(motion) / d(reference left u, v, right u, v), times the pixel sigma: the motion's
  /// covariance from one match's reference pixels is gain * gain^T.
  std::vector<Eigen::Matrix<double, 6, 4>> gain;
  Eigen::Matrix<double, 6, 3> prior_gain = Eigen::Matrix<double, 6, 3>::Zero();  ///< d(motion) / d(prior error)
  Eigen::Matrix3d prior_covariance = Eigen::Matrix3d::Zero();  ///< the prior's, as weighted (with its floor)
};

/// Levenberg-Marquardt on T_prev_curr over the `inliers` of `matches`: four-view bundle
/// adjustment (each point, triangulated in the previous pair, refined with the motion and
/// reprojected into all four images; Huber kernel of `huber_px`) plus the rotation prior.
/// Holding the triangulated points fixed (a transfer error) would treat their noisy depth as
/// exact and shorten the translation over flat floors; see motion_refinement.cpp.
/// `covariance` is that of the motion with the points marginalised out.
MotionRefinementResult refineMotion(const camera::RectifiedRig& rig, std::span<const geometry::QuadMatch> matches,
                                    std::span<const uint32_t> inliers, const Eigen::Isometry3d& T_prev_curr_init,
                                    const RotationPrior& prior, const MotionRefinementParams& params);

/// Buffers of refineMotion, kept by a caller across frames so a warm call allocates nothing.
struct MotionRefinementWorkspace {
  struct Obs {
    Eigen::Vector3d X;                ///< point in the previous left camera [m]
    Eigen::Matrix<double, 8, 1> uv;   ///< left/right previous, left/right current [px]
    uint32_t match = 0;               ///< its index into `matches`
  };
  std::vector<Obs> obs;
  std::vector<Eigen::Vector3d> points, trial_points, gl;
  std::vector<Eigen::Matrix3d> Hll_inv;
  std::vector<Eigen::Matrix<double, 6, 3>> Hpl;
  std::vector<Eigen::Matrix<double, 6, 4>> Gref;  ///< the gradient's reference-pixel part, per point
  std::vector<Eigen::Matrix<double, 6, 4>> Gcur;  ///< ... and its current-pixel part
  std::vector<double> residual_dof;  ///< per point, its residual's degrees of freedom under the noise model
};
/// The same with the buffers of `ws`: identical results. With `sensitivity`, an ok result also
/// fills it (at the refined motion).
MotionRefinementResult refineMotion(const camera::RectifiedRig& rig, std::span<const geometry::QuadMatch> matches,
                                    std::span<const uint32_t> inliers, const Eigen::Isometry3d& T_prev_curr_init,
                                    const RotationPrior& prior, const MotionRefinementParams& params,
                                    MotionRefinementWorkspace& ws, ReferenceSensitivity* sensitivity = nullptr);

}  // namespace seavio::odometry
