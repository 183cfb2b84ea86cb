#pragma once
/// What only the user knows about the vehicle and its scene, kept apart from the tuning
/// (config/profiles/*.yaml, README "Rig profiles"). Every pixel limit derived from it comes
/// from the calibration: the depth band becomes a disparity window through the baseline and
/// focal length, the speed a bound on one frame's visual step.
#include "core/matching/stereo_matcher.hpp"

namespace seavio::odometry {

/// Defaults: a downward-looking AUV rig (config/profiles/auv-downward.yaml).
struct RigProfile {
  /// The fastest the vehicle moves [m/s]; a visual step faster than this times
  /// `speed_margin` is refused as a wrong solution (RANSAC on repeated texture).
  double max_speed_m_s = 3.0;
  /// Nearest scene along the optical axis [m]; 0 = the nearest the rig triangulates
  /// (disparity = the image width).
  double scene_min_depth_m = 1.5;
  /// Farthest [m]; 0 = the farthest the rig triangulates (disparity 1 px).
  double scene_max_depth_m = 12.0;
};

/// `stereo` with the profile's depth band (stereo_matcher.hpp: 0 = the rig's own limit).
inline matching::StereoMatchParams withSceneDepth(matching::StereoMatchParams stereo, const RigProfile& rig) {
  stereo.min_range_m = rig.scene_min_depth_m;
  stereo.max_range_m = rig.scene_max_depth_m;
  return stereo;
}

}  // namespace seavio::odometry
