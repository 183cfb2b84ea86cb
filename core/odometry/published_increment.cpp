/// What the published pose's increment since the previous frame claims as its covariance: the
/// consumer fusing seavio's output (a vehicle navigation filter) takes the step between two
/// poses, not the pose's drift since the start.
#include "core/odometry/odometry.hpp"

namespace seavio::odometry {

void Odometry::claimIncrement(int64_t t_ns, const FrameTrack& t, OdometryResult& r) {
  const TrackingReference& ref = t.reference;
  const PreviousFrame& prev = *previous_;
  // The motion it was chained from is the visual one (rel_cov, also when ICP placed the frame)
  // only on a visual frame whose reference reaches the previous frame through measured poses,
  // and that no map correction moved since either was published.
  // The refined motion's claim takes the pixel noise its residuals show (work_.sensitivity);
  // against a keyframe the previous frame was also placed from, their shared error cancels
  // (increment_covariance.hpp).
  const bool published_visual = r.source == PoseSource::kVision && !t.map_delta_W;
  if (published_visual && t.reference_measured && !moved_since_published_) {
    std::optional<Matrix6d> claim;
    if (t.sensitivity_ok) claim = work_.sensitivity.covariance;
    if (ref.on_keyframe && t.sensitivity_ok && keyframe_->t_ns != prev.t_ns)
      if (const auto shared =
              keyframe_increment_.increment(keyframe_->id, prev.t_ns, work_.sensitivity, work_.quad_reference))
        claim = shared;
    r.increment_covariance = bodyCovarianceSincePrevious(claim ? *claim : t.rel_cov, prev.T_W_R0.inverse() * ref.T_W_ref,
                                                         prev.T_W_R0.inverse() * t.T_W_R0, frontend_.rig().T_B_R0);
  }
  if (published_visual && ref.on_keyframe && t.sensitivity_ok)
    keyframe_increment_.record(keyframe_->id, t_ns, work_.sensitivity, work_.quad_reference,
                               ref.features->points.size());
  else
    keyframe_increment_.forget();
}

}  // namespace seavio::odometry
