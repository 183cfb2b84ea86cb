#pragma once
/// Work the odometry may leave out when the host cannot keep the frame rate (the daemon's
/// degrade ladder, daemon/degrade_ladder.hpp). Each item trades accuracy for time in the
/// order the ladder sheds them; all off by default, and `seavio run` never sets them.
namespace seavio::odometry {

struct LoadShedding {
  /// The feature-count controller (paper Sec. III-B) aims at this fraction of its targets:
  /// fewer features make detection, stereo and temporal matching and the tensor RANSAC
  /// cheaper. 1 = the configured targets.
  double feature_fraction = 1.0;
  /// false: a frame the RANSAC rejects is not retried with the relaxed rescue threshold or
  /// the whole-image search; it coasts on the IMU.
  bool rescue_retries = true;
  /// false: tracked frames make no global-step work (no request to the ICP thread, no
  /// keyframe insertion inline); the map catches up on the frames after the load falls.
  bool global_step = true;

  bool operator==(const LoadShedding&) const = default;
};

}  // namespace seavio::odometry
