#include "core/odometry/odometry.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/common/capacity.hpp"
#include "core/common/covariance.hpp"
#include "core/common/se3.hpp"
#include "core/common/stage_timer.hpp"
#include "core/odometry/chain_covariance.hpp"
#include "core/odometry/motion_refinement.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {
namespace {

/// The stereo matches the feature controller holds (target_stereo_matches): descriptor matches
/// only. Completed points come on top of the features it keeps; counted, they would make it
/// keep fewer features where completion helps most (snow at 10 Hz).
int descriptorStereoMatches(const Quality& q) { return q.stereo_matches - q.stereo_completed; }

}  // namespace

GlobalRefinerParams globalRefinerParams(const OdometryParams& p) {
  GlobalRefinerParams g;
  g.map = p.map;
  g.icp = p.icp;
  g.temporal = p.temporal;
  g.ransac = p.ransac;
  g.min_revisit_age_s = p.min_revisit_age_s;
  g.max_map_correction_m = p.max_map_correction_m;
  g.max_map_correction_rad = p.max_map_correction_rad;
  g.keep_tilt = p.map_keeps_tilt;
  g.revisit_keyframe_distance_m = p.revisit_keyframe_distance_m;
  g.revisit_max_points = p.revisit_max_points;
  g.revisit_min_inliers = p.revisit_min_inliers;
  g.max_revisit_correction_m = p.max_revisit_correction_m;
  g.revisit_search_sigmas = p.revisit_search_sigmas;
  g.max_revisit_search_m = p.max_revisit_search_m;
  g.revisit_candidates = p.revisit_candidates;
  g.revisit_disc_candidates = p.revisit_disc_candidates;
  g.revisit_agreement_m = p.revisit_agreement_m;
  g.revisit_witness_window_s = p.revisit_witness_window_s;
  return g;
}

Odometry::Odometry(camera::StereoRectifier rectifier, const imu::ImuNoise& imu_noise, const OdometryParams& params,
                   NowNsFn now)
    : frontend_(std::move(rectifier), params.features, withSceneDepth(params.stereo, params.rig), params.illumination,
                params.snow, params.ripple_notch),
      imu_noise_(imu_noise),
      params_(params),
      now_(std::move(now)),
      controller_(params.features.controller),
      ransac_(frontend_.rig(), params.ransac),
      rescue_ransac_(frontend_.rig(),
                     [&] {
                       geometry::QuadRansacParams p = params.ransac;
                       p.inlier_threshold_px = std::max(params.rescue_inlier_threshold_px, 1e-3);
                       p.min_inliers = std::min(p.min_inliers, std::max(params.rescue_min_inliers, 3));
                       return p;
                     }()),
      refiner_(frontend_.rig(), globalRefinerParams(params)),
      deferred_(params.mode == Mode::kGlobal &&
                (params.global_delivery == GlobalDelivery::kDeferred || params.global_link != nullptr)),
      rng_(params.seed),
      filter_([&] {
        imu::ErrorStateParams e = params.inertial;
        e.noise = imu_noise;
        // The vehicle may be under way at any speed its profile allows when the odometry starts
        // (a watchdog restart mid-dive, a car already driving): a tighter prior would gate out
        // the very visual motions that tell the filter its velocity.
        e.initial_velocity_sigma_m_s = params.rig.max_speed_m_s;
        return e;
      }()) {
  // Patch refinement aligns the other three pixels of each match to its reference-left
  // template: the published claim's noise model (ReferenceSensitivity); the fit is the same.
  params_.refinement.template_aligned = params_.patch_refinement;
}

GlobalRefiner Odometry::makeGlobalRefiner(NowNsFn now) const {
  return GlobalRefiner(frontend_.rig(), globalRefinerParams(params_), std::move(now));
}

std::optional<GlobalRequest> Odometry::takeGlobalRequest() {
  std::optional<GlobalRequest> out = std::move(pending_request_);
  pending_request_.reset();
  return out;
}

void Odometry::makeGlobalRequest(const FrameFeatures& frame, const Eigen::Isometry3d& T_W_R0,
                                 const OdometryResult& r, bool first_frame) {
  GlobalRequest q;
  q.frame_id = frame.seq;
  q.t_ns = frame.t_ns;
  q.T_W_R0 = T_W_R0;
  q.pose_covariance = pose_covariance_;
  q.first_frame = first_frame;
  q.points_R0.reserve(frame.stereo.points.size());
  for (const auto& sp : frame.stereo.points) q.points_R0.push_back(sp.p_R0);
  q.features.points = frame.stereo.points;
  q.features.laplacian_sign = frame.stereo.laplacian_sign;
  // A deep copy: the request may be refined on another thread while the frontend reuses
  // its buffers.
  q.features.descriptors = frame.stereo.descriptors.clone();
  q.local = r;
  q.last_applied_correction = last_applied_correction_;
  if (params_.global_link) {
    params_.global_link->submit(std::move(q));
  } else {
    pending_request_ = std::move(q);
  }
}

void Odometry::applyGlobalCorrection(const GlobalCorrection& c) {
  // Only the part not already delivered by earlier corrections (GlobalCorrection::increment_W).
  const Eigen::Isometry3d delta = c.increment_W ? *c.increment_W : c.correction_W;
  if (!initialised_ || !finitePose(delta)) return;
  last_applied_correction_ = c.frame_id;
  moved_since_published_ = true;
  // The correction is a delta in W measured at an older frame; everything tracked since was
  // chained onto that frame's pose, so the same delta moves it too. A correction is not
  // motion: the velocity is only turned with the frame.
  state_.T_W_B = orthonormalized(delta * state_.T_W_B);
  state_.v_W = delta.linear() * state_.v_W;
  if (previous_) previous_->T_W_R0 = orthonormalized(delta * previous_->T_W_R0);
  // The next frame is tracked against the keyframe: it moves with the chain, or that frame
  // would be placed where the keyframe was before the correction and lose it.
  if (keyframe_) keyframe_->T_W_R0 = orthonormalized(delta * keyframe_->T_W_R0);
  if (c.revisit_used) {
    c.shrink(pose_covariance_);
    if (keyframe_) c.shrink(keyframe_->pose_covariance);
    ++deferred_revisits_;
  }
}

OdometryResult Odometry::process(const StereoFrame& frame, std::span<const ImuSample> imu) {
  // Into the buffers of an earlier frame, which track() hands back (no allocation).
  frontend_.process(frame, controller_.threshold(), now_, frontend_ws_, spare_frame_, parallel_);
  return track(std::move(spare_frame_), imu);
}

void Odometry::initialise(const FrameFeatures& frame, std::span<const ImuSample> imu) {
  state_ = NavState{};
  state_.t_ns = frame.t_ns;
  pose_covariance_ = Matrix6d::Identity() * 1e-12;
  if (params_.prediction == Prediction::kImu) {
    // III-A: attitude from gravity over the last second before the first frame, the gyro bias
    // from it if the vehicle was still; a moving start keeps the tilt loose for the first
    // visual velocities to settle (ErrorStateFilter::start never assumes rest).
    std::vector<ImuSample> recent;
    for (const ImuSample& s : imu)
      if (s.t_ns <= frame.t_ns && s.t_ns > frame.t_ns - 1'000'000'000) recent.push_back(s);
    filter_.start(frame.t_ns, recent);
    const NavState s = filter_.state();
    state_.T_W_B.linear() = s.T_W_B.linear();
    state_.gyro_bias_rad_s = s.gyro_bias_rad_s;
    filter_stale_ = recent.empty();
  }
  fix_pose_covariance_ = pose_covariance_;
  fix_filter_covariance_ = filter_.poseCovarianceW();
  previous_coasted_ = false;
  initialised_ = true;
}

OdometryResult Odometry::track(FrameFeatures&& frame, std::span<const ImuSample> imu) {
  pollLinkedCorrections();
  pending_request_.reset();
  StageTimer timer(now_);
  OdometryResult r = resultOf(frame);
  bufferImu(imu);
  if (!initialised_) return trackFirstFrame(std::move(frame), r, timer);

  FrameTrack t;
  t.prediction = predict(frame.t_ns);          // III-A
  estimateVisualMotion(frame, t, r, timer);    // III-C: matching and RANSAC, with its retries
  if (t.vision_ok && params_.patch_refinement) {
    refineWithPatches(frame, t, r);
    r.times.patch_ms = timer.lap_ms();
    r.times.tensor_ms += r.times.patch_ms;
  }
  r.quality.ransac_inliers = static_cast<int>(work_.ransac.inliers.size());
  refineWithRotationPrior(t);                  // III-C: the four-view refinement
  // Tensor stage = RANSAC (and its retries), the patches and the four-view refinements.
  r.times.tensor_ms += timer.lap_ms();
  registerFrame(frame, t, r);                  // III-D/E: ICP against the reference or the map
  r.times.icp_ms = timer.lap_ms();
  acceptFrame(t, r);
  updatePose(frame.t_ns, t, r);
  claimIncrement(frame.t_ns, t, r);
  moved_since_published_ = false;
  previous_coasted_ = r.source != PoseSource::kVision;
  last_motion_ = previous_->T_W_R0.inverse() * t.T_W_R0;
  last_dt_s_ = t.prediction.dt_s;
  publishState(r);
  if (params_.mode == Mode::kGlobal && r.source == PoseSource::kVision && shed_.global_step)
    insertIntoMap(frame, t.T_W_R0, r, false);
  if (t.keyframe_usable) updateKeyframe(frame, t, r);
  // The outgoing previous frame's buffers go back to the caller's FrameFeatures.
  std::swap(previous_->features, frame);
  previous_->T_W_R0 = t.T_W_R0;
  previous_->t_ns = r.t_ns;
  r.times.total_ms = r.times.rectify_ms + r.times.features_ms + r.times.stereo_ms + timer.total_ms();
  // Paper III-B's controller for the next frame, also holding the inliers against the previous
  // frame (target_inliers: the overlap decides how many features become inliers).
  updateController(r.quality.features_left, descriptorStereoMatches(r.quality),
                   t.reference_is_previous ? r.quality.ransac_inliers : -1);
  return r;
}

void Odometry::pollLinkedCorrections() {
  if (!params_.global_link) return;
  // Corrections of earlier frames first, so this frame is predicted from corrected poses.
  GlobalCorrection c;
  while (params_.global_link->poll(c)) applyGlobalCorrection(c);
}

OdometryResult Odometry::resultOf(const FrameFeatures& frame) const {
  OdometryResult r;
  r.t_ns = frame.t_ns;
  r.seq = frame.seq;
  r.times = frame.times;
  r.quality.features_left = static_cast<int>(frame.left.keypoints.size());
  r.quality.features_right = static_cast<int>(frame.right.keypoints.size());
  r.quality.stereo_matches = static_cast<int>(frame.stereo.points.size());
  r.quality.stereo_completed = frame.stereo.completed;
  r.quality.detector_threshold = frame.detector_threshold;
  return r;
}

OdometryResult Odometry::trackFirstFrame(FrameFeatures&& frame, OdometryResult& r, StageTimer& timer) {
  initialise(frame, imu_buffer_);
  publishState(r);
  r.source = PoseSource::kInit;
  // Paper III-B: a proportional controller holds the feature count (and, in snow, the stereo
  // matches) for the next frame; nothing tracked yet, so no inliers.
  updateController(r.quality.features_left, descriptorStereoMatches(r.quality), -1);
  const Eigen::Isometry3d T_W_R0 = state_.T_W_B * frontend_.rig().T_B_R0;
  if (params_.mode == Mode::kGlobal) {
    fillCloud(frame);
    insertIntoMap(frame, T_W_R0, r, true);
  }
  if (params_.keyframe_tracking) newKeyframe(frame, T_W_R0, r.t_ns);
  previous_ = PreviousFrame{std::move(frame), T_W_R0, r.t_ns};
  r.times.total_ms = r.times.rectify_ms + r.times.features_ms + r.times.stereo_ms + timer.total_ms();
  return r;
}

void Odometry::updateController(int features, int stereo_matches, int inliers) {
  // Under load shedding the controller sees the counts as if they were 1 / fraction times
  // larger, so it settles where the real ones are that fraction of every target.
  const double f = shed_.feature_fraction;
  if (!(f > 0.0) || f >= 1.0) {
    controller_.update(features, stereo_matches, inliers);
    return;
  }
  const auto scale = [f](int n) { return static_cast<int>(std::lround(n / f)); };
  controller_.update(scale(features), scale(stereo_matches), inliers < 0 ? inliers : scale(inliers));
}

std::size_t Odometry::mapMemoryBytes() const { return refiner_.memoryBytes(); }

void Odometry::publishState(OdometryResult& r) {
  r.T_W_B = state_.T_W_B;
  r.v_W = state_.v_W;
  r.covariance = pose_covariance_;
}

}  // namespace seavio::odometry
