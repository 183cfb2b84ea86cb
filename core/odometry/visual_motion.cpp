/// Odometry's matching stage (paper III-C): the frame's stereo points matched against the
/// reference inside the windows the prediction gives, and the quadrifocal tensor of the two
/// pairs found by RANSAC. When that fails the stage tries again, in a fixed order of attempts.
#include <algorithm>
#include <array>

#include "core/common/capacity.hpp"
#include "core/odometry/odometry.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {
namespace {

/// The attempts at a visual motion, in the order tried; each runs only when every earlier one
/// failed, and only where it applies (Odometry::estimateVisualMotion).
enum class Attempt {
  kReference,         ///< the keyframe (or the previous frame), RANSAC at its own threshold
  kPreviousFrame,     ///< the keyframe lost (a turn, texture gone): the previous frame instead
  kRescue,            ///< the same matches, the rescue RANSAC's wider threshold and smaller count
  kRescueWholeImage,  ///< matched again over the whole image, then the rescue RANSAC
};
constexpr std::array<Attempt, 4> kAttemptOrder{Attempt::kReference, Attempt::kPreviousFrame, Attempt::kRescue,
                                               Attempt::kRescueWholeImage};

/// Why no attempt gave a visual estimate: the first stage that left fewer candidates than the
/// smallest accepted inlier count `need` (the rescue's when it runs), else RANSAC.
RefusalFigures visionRefusal(std::size_t stereo_points, std::size_t temporal_matches,
                             const geometry::RansacResult& ransac, int min_inliers, int need) {
  const auto count = [](std::size_t n) { return static_cast<double>(n); };
  if (static_cast<int>(stereo_points) < need) return {Refusal::kStereoPoints, count(stereo_points), double(need)};
  if (static_cast<int>(temporal_matches) < need)
    return {Refusal::kTemporalMatches, count(temporal_matches), double(need)};
  if (ransac.status == geometry::RansacStatus::kOk && static_cast<int>(ransac.inliers.size()) >= min_inliers)
    return {Refusal::kNonFinite, 0, 0};  // enough inliers: only a non-finite pose fails
  return {Refusal::kInliers, ransac.status == geometry::RansacStatus::kOk ? count(ransac.inliers.size()) : 0.0,
          double(min_inliers)};
}

bool ransacAccepted(const geometry::RansacResult& ransac, int min_inliers) {
  return ransac.status == geometry::RansacStatus::kOk && static_cast<int>(ransac.inliers.size()) >= min_inliers &&
         finitePose(ransac.T_prev_curr);
}

}  // namespace

TrackingReference Odometry::previousReference(const MotionPrediction& p) const {
  TrackingReference ref;
  ref.features = &previous_->features.stereo;
  ref.T_W_ref = previous_->T_W_R0;
  ref.T_ref_curr_pred = p.T_prev_curr;
  ref.R_ref_curr_gyro = p.T_prev_curr.rotation();
  ref.dt_s = p.dt_s;
  return ref;
}

TrackingReference Odometry::keyframeReference(const MotionPrediction& p, int64_t t_ns) const {
  TrackingReference ref;
  ref.features = &keyframe_->features;
  ref.T_W_ref = keyframe_->T_W_R0;
  ref.T_ref_curr_pred = orthonormalized(ref.T_W_ref.inverse() * previous_->T_W_R0 * p.T_prev_curr);
  ref.R_ref_curr_gyro = keyframe_->R_kf_prev_gyro * p.T_prev_curr.rotation();
  ref.gyro_covariance = keyframe_->gyro_covariance;
  ref.dt_s = 1e-9 * static_cast<double>(t_ns - keyframe_->t_ns);
  ref.on_keyframe = true;
  return ref;
}

void Odometry::matchReference(const FrameFeatures& frame, const FrameTrack& t, bool whole_image) {
  matching::TemporalMatchParams match = params_.temporal;
  if (whole_image) match.use_prediction = false;
  matching::matchTemporal(*t.reference.features, frame.stereo, frontend_.rig(), t.reference.T_ref_curr_pred,
                          t.prediction.covariance, match, work_.temporal_ws, work_.temporal);
  // The RANSAC's correspondences; room for the guided tracks too (at most one per reference
  // point), so none reallocates.
  std::vector<geometry::QuadMatch>& quads = work_.quads;
  std::vector<uint32_t>& quad_reference = work_.quad_reference;
  quads.clear();
  quad_reference.clear();
  const std::size_t room = work_.temporal.size() + t.reference.features->points.size();
  reserveWithHeadroom(quads, room);
  reserveWithHeadroom(quad_reference, room);
  for (const auto& m : work_.temporal) {
    const auto& a = t.reference.features->points[static_cast<std::size_t>(m.prev)];
    const auto& b = frame.stereo.points[static_cast<std::size_t>(m.curr)];
    quads.push_back(geometry::QuadMatch{a.uv_left, a.uv_right, b.uv_left, b.uv_right});
    quad_reference.push_back(static_cast<uint32_t>(m.prev));
  }
}

bool Odometry::rescue(FrameTrack& t) {
  if (static_cast<int>(work_.quads.size()) < params_.rescue_min_inliers) return false;
  geometry::RansacResult second = rescue_ransac_.estimate(work_.quads, t.reference.T_ref_curr_pred, rng_);
  if (!ransacAccepted(second, params_.rescue_min_inliers)) return false;
  work_.ransac = std::move(second);
  t.rescued = true;
  return true;
}

void Odometry::estimateVisualMotion(const FrameFeatures& frame, FrameTrack& t, OdometryResult& r,
                                    StageTimer& timer) {
  t.keyframe_usable = keyframe_.has_value() && params_.keyframe_tracking;
  t.reference = t.keyframe_usable ? keyframeReference(t.prediction, frame.t_ns) : previousReference(t.prediction);
  const bool rescue_on = params_.rescue_inlier_threshold_px > 0 && shed_.rescue_retries;
  const auto applies = [&](Attempt a) {
    switch (a) {
      case Attempt::kReference: return true;
      case Attempt::kPreviousFrame: return t.reference.on_keyframe && keyframe_->t_ns != previous_->t_ns;
      case Attempt::kRescue: return rescue_on;
      // After a lost frame the coasting prediction can be too wrong for its windows (a fast
      // turn, a velocity gone stale): the whole image once, so tracking comes back.
      case Attempt::kRescueWholeImage: return rescue_on && params_.temporal.use_prediction;
    }
    return false;
  };
  for (const Attempt a : kAttemptOrder) {
    if (!applies(a)) continue;
    if (a == Attempt::kPreviousFrame) t.reference = previousReference(t.prediction);
    if (a != Attempt::kRescue) {
      matchReference(frame, t, a == Attempt::kRescueWholeImage);
      r.times.temporal_ms += timer.lap_ms();
    }
    if (a == Attempt::kReference || a == Attempt::kPreviousFrame) {
      ransac_.estimate(work_.quads, t.reference.T_ref_curr_pred, rng_, work_.ransac);
      t.vision_ok = ransacAccepted(work_.ransac, params_.min_inliers);
    } else {
      t.vision_ok = rescue(t);
    }
    r.times.tensor_ms += timer.lap_ms();
    if (t.vision_ok) break;
  }
  r.quality.temporal_matches = static_cast<int>(work_.temporal.size());
  t.reference_is_previous = !t.reference.on_keyframe || keyframe_->t_ns == previous_->t_ns;
  if (!t.vision_ok) {
    const int need = params_.rescue_inlier_threshold_px > 0 ? std::min(params_.min_inliers, params_.rescue_min_inliers)
                                                            : params_.min_inliers;
    t.refusal = visionRefusal(frame.stereo.points.size(), work_.temporal.size(), work_.ransac, params_.min_inliers,
                              need);
  }
}

}  // namespace seavio::odometry
