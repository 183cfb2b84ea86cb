#pragma once
/// Stereo matching along rectified rows and triangulation (paper section III, "spatially
/// matched using epipolar constraints ... back-projection into 3D space").
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/camera/rectified_rig.hpp"
#include "core/matching/patch_alignment.hpp"

namespace seavio::matching {

/// Stereo points completed by patch alignment (core/matching/stereo_completion.hpp): left
/// features descriptor matching left without a right partner, aligned in the right image at
/// the disparity their matched neighbours predict.
struct StereoCompletionParams {
  bool enabled = true;
  /// Only frames whose descriptor matching paired less than this share of the left features
  /// are completed: snow (0.26-0.49 at 1 and 10 Hz), not clear water (0.54-0.76), where the
  /// points completion adds would let the feature controller reach its inlier target with
  /// fewer, weaker features (1 Hz plain heading noise +6 % with completion on every frame).
  double max_matched_share = 0.5;
  int neighbours = 5;                     ///< matched points whose median disparity is the start
  double max_neighbour_distance_px = 40;  ///< the farthest of them at most this far [px]
  double max_disparity_spread_px = 3;     ///< their disparities within this (no depth edge) [px]
  double start_spacing_px = 2;            ///< alignments start at the prediction and this either side [px]
  double max_row_difference_px = 0.5;     ///< the aligned right pixel's row off the left's [px]
  double min_separation_px = 1.5;         ///< a matched point this close: the same blob, not tried [px]
  PatchAlignParams patch;                 ///< the left patch found in the right image
};

struct StereoMatchParams {
  /// Nearest scene along the optical axis [m]; with max_range_m sets the disparity window.
  /// 0 = the nearest the rig triangulates (disparity = the image width). A profile's depth
  /// band (core/odometry/rig_profile.hpp) narrows it.
  double min_range_m = 0.0;
  double max_range_m = 0.0;          ///< farthest [m]; 0 = the farthest it triangulates (1 px)
  double max_row_difference_px = 1.0;  ///< rectified rows agree to this [px]
  float max_descriptor_distance = 0.35f;  ///< L2 (normalised float) or bits/256 scaled for binary
  float ratio = 0.8f;                ///< Lowe ratio test, best / second best
  bool left_right_check = true;      ///< keep only mutual best matches
  StereoCompletionParams completion;
};

/// The disparity search window [px] the depth band gives
/// through the rig's baseline and focal length; an unset bound is the rig's own limit.
struct DisparityWindow {
  double min_px = 1.0;
  double max_px = 0.0;
};
inline DisparityWindow disparityWindow(const camera::RectifiedRig& rig, const StereoMatchParams& params) {
  DisparityWindow w;
  w.min_px = params.max_range_m > 0 ? rig.disparityAt(params.max_range_m) : 1.0;
  w.max_px = params.min_range_m > 0 ? rig.disparityAt(params.min_range_m) : static_cast<double>(rig.width);
  return w;
}

/// One feature seen in both rectified images of a pair, with its 3D point in R0.
struct StereoPoint {
  int left_index = -1;    ///< into the left keypoints/descriptors
  int right_index = -1;   ///< into the right keypoints/descriptors
  Eigen::Vector2f uv_left = Eigen::Vector2f::Zero();   ///< rectified left pixel
  Eigen::Vector2f uv_right = Eigen::Vector2f::Zero();  ///< rectified right pixel
  Eigen::Vector3f p_R0 = Eigen::Vector3f::Zero();      ///< triangulated point in R0 [m]
};

/// Scratch of matchStereo kept across frames by its owner (Frontend's workspace), so a warm
/// call allocates nothing: vectors are cleared and refilled, never freed.
struct StereoMatchWorkspace {
  /// Best and second-best candidate of one keypoint (ratio test, left-right check).
  struct Best {
    int index = -1;
    float distance = std::numeric_limits<float>::max();
    float second = std::numeric_limits<float>::max();
    void offer(int i, float d) {
      if (d < distance) {
        second = distance;
        distance = d;
        index = i;
      } else if (d < second) {
        second = d;
      }
    }
  };
  std::vector<int> by_row;   ///< right keypoints sorted by row
  std::vector<float> rows;   ///< their rows
  std::vector<Best> best_left, best_right;
};

/// Matches left to right keypoints on (nearly) the same rectified row within the disparity
/// window, by descriptor distance with ratio test and left-right consistency, then
/// triangulates. Keypoints whose `class_id` holds the sign of the Laplacian (SURF) are only
/// compared with keypoints of the same sign. Descriptors: one row per keypoint.
std::vector<StereoPoint> matchStereo(const std::vector<cv::KeyPoint>& left, const cv::Mat& left_descriptors,
                                     const std::vector<cv::KeyPoint>& right, const cv::Mat& right_descriptors,
                                     const camera::RectifiedRig& rig, const StereoMatchParams& params);
/// The same into `out` (cleared first), with the scratch of `ws`: identical results, and no
/// allocation once `ws` and `out` have grown to the frame's size.
void matchStereo(const std::vector<cv::KeyPoint>& left, const cv::Mat& left_descriptors,
                 const std::vector<cv::KeyPoint>& right, const cv::Mat& right_descriptors,
                 const camera::RectifiedRig& rig, const StereoMatchParams& params, StereoMatchWorkspace& ws,
                 std::vector<StereoPoint>& out);

/// Threshold in the descriptor's own unit: `max_descriptor_distance` for float descriptors,
/// scaled to bits for binary ones.
float descriptorThreshold(const cv::Mat& descriptors, float max_descriptor_distance);

}  // namespace seavio::matching
