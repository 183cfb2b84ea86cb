#pragma once
/// Reference stereo points that descriptor matching missed, found again in the current pair
/// by patch alignment where the tensor's motion puts them (paper III-C's four-view
/// correspondences, completed after the fact).
///
/// Why: in marine snow a share of the floor features is re-detected elsewhere or not at all
/// between two frames (a particle crossed the blob, the detector threshold moved), so only
/// ~40 % of the reference's stereo points find a descriptor match against ~58 % in clear water,
/// although most of those points are still plainly in view. Once RANSAC has the motion, each
/// missed point's reference-left patch is aligned in the reference right image and in both
/// current images (core/matching/patch_alignment.hpp), starting where the motion projects it;
/// the quads it yields are judged by the same RANSAC threshold as the descriptor matches.
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera/rectified_rig.hpp"
#include "core/geometry/quadrifocal_ransac.hpp"
#include "core/matching/patch_alignment.hpp"
#include "core/matching/temporal_matcher.hpp"
#include "core/odometry/reference_alignment.hpp"

namespace seavio::odometry {

struct GuidedTrackParams {
  bool enabled = true;
  /// Points projected closer than this to the image border are not tried [px] (the patch
  /// must fit around the start and the shift).
  double border_px = 10.0;
};

/// Appends to `quads` one QuadMatch (left/right of the reference, left/right of the current
/// frame) for every point of `ref` not in `matched` (TemporalMatch::prev indices) whose
/// patch aligns in all three other images. T_ref_curr maps current R0 points into the
/// reference R0; `cache` (may be null) keeps the reference-right alignments across frames
/// tracked against one keyframe; `used` ends with one flag per reference point: 1 matched, 2 a
/// track added (in the order of the new entries of `quads`), 0 neither. Returns how many it
/// added.
int trackUnmatched(const matching::StereoFeatures& ref, const cv::Mat& ref_left, const cv::Mat& ref_right,
                   const cv::Mat& curr_left, const cv::Mat& curr_right, const camera::RectifiedRig& rig,
                   const Eigen::Isometry3d& T_ref_curr, std::span<const matching::TemporalMatch> matched,
                   const matching::PatchAlignParams& patch, const GuidedTrackParams& params,
                   ReferenceAlignments* cache, std::vector<uint8_t>& used, std::vector<geometry::QuadMatch>& quads);

}  // namespace seavio::odometry
