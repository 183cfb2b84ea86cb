#pragma once
/// Sub-pixel refinement of a matched feature's position by aligning image patches: the
/// reference image's patch around a keypoint, found again in another image near where the
/// descriptor match put it (Lucas-Kanade, translation only, on zero-mean unit-variance
/// patches so the vehicle's moving lights change gain and offset freely).
///
/// Why: SURF's keypoints come from box-filter extrema interpolated over a coarse scale
/// space; at 1 Hz and 1.5 m steps the same point is detected some 0.5 px apart in the two
/// frames, and vision's per-step yaw (the gyro bias's only observation, docs/architecture.md)
/// carries that noise. Aligning the reference patch instead measures all images of a point
/// against one anchor.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace seavio::matching {

struct PatchAlignParams {
  int half_size_px = 7;         ///< patch side 2 h + 1 [px]
  int max_iterations = 10;
  double max_shift_px = 1.5;    ///< refined position further than this from the start: rejected [px]
  double min_zncc = 0.8;        ///< zero-mean normalised cross-correlation at the end, else rejected
  double min_stddev_dn = 2.0;   ///< flat patches (sensor noise only) are not aligned [grey levels]
  /// det / trace^2 of the gradients' 2x2 moment (about the smaller over the larger
  /// eigenvalue): below it the patch is an edge, sliding along itself.
  double min_eigen_ratio = 0.05;
  /// Huber width on the per-pixel residual of the normalised patches (unit variance): pixels
  /// further off weigh c / |r|. A marine-snow dot (or its filled-in spot) in one patch and
  /// not the other, a glint, an edge of the lit area pull a least-squares shift towards
  /// them; weighted down, the floor around them sets it. 0: plain least squares.
  double huber = 0.3;
};

struct PatchAlignment {
  bool ok = false;
  Eigen::Vector2f uv = Eigen::Vector2f::Zero();  ///< refined position (the start when !ok) [px]
  float zncc = 0;
};

/// The in-plane turn a near-nadir motion gives a patch: a reference offset appears in the
/// current image turned by the roll about the optical axis (R_ref_curr: current R0 axes in
/// the reference R0); scale it by the depth ratio ref / curr for the full warp `A`.
Eigen::Matrix2f inPlaneTurn(const Eigen::Matrix3d& R_ref_curr);

/// The reference patch, sampled once for all images it is looked for in: zero-mean,
/// unit-variance grey levels and their gradients (inverse compositional: the Gauss-Newton
/// Hessian is the template's, fixed, so each iteration samples the image patch once).
struct PatchTemplate {
  static constexpr int kMaxHalf = 15;
  static constexpr int kMaxSamples = (2 * kMaxHalf + 1) * (2 * kMaxHalf + 1);
  bool ok = false;  ///< false: outside the image, or too flat or edge-like to align
  int half_size_px = 0;
  float values[kMaxSamples];
  float grad_x[kMaxSamples];
  float grad_y[kMaxSamples];
  Eigen::Matrix2f hessian_inverse = Eigen::Matrix2f::Zero();
};

/// The patch of `ref` (CV_8UC1) centred on `ref_uv`.
PatchTemplate makePatchTemplate(const cv::Mat& ref, const Eigen::Vector2f& ref_uv, const PatchAlignParams& params);

/// Where `tmpl` lies in `img` (CV_8UC1), starting from `uv0`. `A` maps an offset in the
/// template to the offset in `img` (the in-plane rotation and scale predicted by the motion;
/// identity for a rectified stereo partner). Patches reaching outside `img` are rejected.
PatchAlignment alignPatch(const PatchTemplate& tmpl, const cv::Mat& img, const Eigen::Vector2f& uv0,
                          const Eigen::Matrix2f& A, const PatchAlignParams& params);

/// Both in one: where the patch of `ref` (CV_8UC1) centred on `ref_uv` lies in `img` (CV_8UC1), starting
/// from `uv0`. `A` maps an offset in the reference patch to the offset in `img` (the in-plane
/// rotation and scale predicted by the motion; identity for a rectified stereo partner).
/// Patches reaching outside either image are rejected.
PatchAlignment alignPatch(const cv::Mat& ref, const Eigen::Vector2f& ref_uv, const cv::Mat& img,
                          const Eigen::Vector2f& uv0, const Eigen::Matrix2f& A, const PatchAlignParams& params);

}  // namespace seavio::matching
