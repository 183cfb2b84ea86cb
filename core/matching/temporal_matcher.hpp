#pragma once
/// Inter-frame matching pruned by the IMU prediction (paper section III-C): every stereo
/// point of the previous frame is moved with the predicted motion and projected into the
/// current left and right images; candidates are searched only inside a window sized by the
/// prediction's uncertainty.
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera/rectified_rig.hpp"
#include "core/matching/stereo_matcher.hpp"

namespace seavio::matching {

struct TemporalMatchParams {
  bool use_prediction = true;        ///< false = search the whole image (for comparison)
  /// Window half-size = this * predicted pixel sigma + min, the sigma being the predicted
  /// motion's covariance projected into the image at the point's depth; no cap but the image
  /// itself, so a fast rig's wide windows are searched, not cut.
  double sigma_multiplier = 3.0;
  double min_window_px = 6.0;        ///< [px] floor on the half-size (feature localisation)
  float max_descriptor_distance = 0.35f;
  float ratio = 0.85f;
};

/// A stereo point of the previous frame matched to one of the current frame.
struct TemporalMatch {
  int prev = -1;  ///< index into the previous frame's StereoPoints
  int curr = -1;  ///< index into the current frame's StereoPoints
  float distance = 0;
};

/// One frame's matchable content: its stereo points and the left descriptors of their
/// keypoints (row i of `descriptors` belongs to `points[i]`).
struct StereoFeatures {
  std::vector<StereoPoint> points;
  cv::Mat descriptors;
  std::vector<int> laplacian_sign;  ///< per point, from the keypoint's class_id (-1 = unknown)
  /// How many of `points`, at the end, stereo completion added (stereo_completion.hpp); the
  /// rest are descriptor matches.
  int completed = 0;
};

/// Scratch of matchTemporal kept across frames by its owner, so a warm call allocates nothing:
/// the pixel grid is stored flat (counting sort of the points by cell) instead of
/// one vector per cell, and every buffer is refilled, never freed.
struct TemporalMatchWorkspace {
  std::vector<int> cell_start;   ///< grid cell c holds cell_points[cell_start[c] .. cell_start[c + 1])
  std::vector<int> cell_points;  ///< current points, by cell, ascending within a cell
  std::vector<TemporalMatch> best;
  std::vector<float> second;
  std::vector<int> best_prev_of_curr;
  std::vector<float> best_prev_dist;
};

/// Matches `prev` to `curr` given the predicted motion T_prev_curr (maps points of the
/// current R0 into the previous R0) and its 6x6 covariance (rotation [rad], translation [m]).
std::vector<TemporalMatch> matchTemporal(const StereoFeatures& prev, const StereoFeatures& curr,
                                         const camera::RectifiedRig& rig, const Eigen::Isometry3d& T_prev_curr,
                                         const Eigen::Matrix<double, 6, 6>& covariance,
                                         const TemporalMatchParams& params);
/// The same into `out` (cleared first) with the scratch of `ws`: identical matches, no
/// allocation once `ws` and `out` have grown to the frames' sizes.
void matchTemporal(const StereoFeatures& prev, const StereoFeatures& curr, const camera::RectifiedRig& rig,
                   const Eigen::Isometry3d& T_prev_curr, const Eigen::Matrix<double, 6, 6>& covariance,
                   const TemporalMatchParams& params, TemporalMatchWorkspace& ws, std::vector<TemporalMatch>& out);

/// Half-size of the search window [px] for a point at depth z_m given the motion covariance.
double predictionWindowPx(const camera::RectifiedRig& rig, double z_m, const Eigen::Matrix<double, 6, 6>& covariance,
                          const TemporalMatchParams& params);

}  // namespace seavio::matching
