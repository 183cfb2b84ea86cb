#pragma once
/// Ground-truth check of inter-frame matches, for measuring what the IMU pruning of paper
/// section III-C buys: a match is correct when the previous frame's point, moved by
/// the true motion, lands on the current point in both rectified images.
#include <vector>

#include <Eigen/Geometry>

#include "core/camera/rectified_rig.hpp"
#include "core/matching/temporal_matcher.hpp"

namespace seavio::matching {

/// Counts of a match set judged against the true motion.
struct MatchCorrectness {
  int matches = 0;  ///< matches judged
  int correct = 0;  ///< of them, consistent with the true motion
  /// correct / matches; 0 for an empty set.
  double precision() const { return matches > 0 ? static_cast<double>(correct) / matches : 0.0; }
};

/// Judges `matches` between `prev` and `curr` against the true motion `T_prev_curr_true`
/// (maps points of the current R0 into the previous R0). A match is correct when the previous
/// point's triangulated p_R0, moved into the current R0, projects within `tolerance_px` [px] of
/// the current point in the left and in the right rectified image. Indices out of range and
/// points behind the camera count as wrong.
MatchCorrectness judgeMatches(const StereoFeatures& prev, const StereoFeatures& curr,
                              const std::vector<TemporalMatch>& matches, const camera::RectifiedRig& rig,
                              const Eigen::Isometry3d& T_prev_curr_true, double tolerance_px = 3.0);

}  // namespace seavio::matching
