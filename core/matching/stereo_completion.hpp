#pragma once
/// Stereo points that descriptor matching missed, completed by patch alignment along the
/// rectified row at the disparity their matched neighbours predict.
///
/// Why: marine snow puts particles, at their own parallax, inside many floor features' SURF
/// windows (~24-60 px at the scales a 1 Hz frame keeps), so the left and right descriptors of
/// one floor point differ and the ratio test drops it: on paper-snow at an equal detector
/// threshold 723 stereo points against plain's 1282 from the same ~2000 features. The 15 px
/// patch around the keypoint mostly misses the particles, and the floor is smooth at that
/// scale, so the neighbours' disparity puts the alignment within its reach. A particle's own
/// keypoint, at another depth, does not align at the floor's disparity and is dropped.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera/rectified_rig.hpp"
#include "core/matching/stereo_matcher.hpp"

namespace seavio::matching {

/// Scratch of completeStereo kept by its owner across frames (no allocation once grown).
struct StereoCompletionWorkspace {
  std::vector<int> by_row;      ///< matched points sorted by left row
  std::vector<uint8_t> matched; ///< per left keypoint: already in a stereo point
};

/// Appends to `points` a StereoPoint (right_index -1) for every left keypoint not yet in one
/// whose patch of `left_image` aligns in `right_image` on its row, at a disparity inside the
/// stereo range (disparityWindow: the rig profile's depth band); `stereo.completion` holds the rules.
/// Returns how many it added; 0 when disabled, when the images are missing, or when the
/// descriptors already paired `max_matched_share` of the left features.
int completeStereo(const std::vector<cv::KeyPoint>& left, const cv::Mat& left_image, const cv::Mat& right_image,
                   const camera::RectifiedRig& rig, const StereoMatchParams& stereo, StereoCompletionWorkspace& ws,
                   std::vector<StereoPoint>& points);

}  // namespace seavio::matching
