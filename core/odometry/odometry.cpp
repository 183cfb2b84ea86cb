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

/// The inertial estimator's predicted motion as a body transform (previous <- current).
Eigen::Isometry3d bodyMotion(const imu::RelativeMotion& m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = m.R_prev_curr;
  T.translation() = m.p_prev_curr;
  return T;
}

/// The covariance of a camera motion against the reference (left perturbation in the reference
/// camera), carried to the previous frame by `T_prev_ref` (rig frames) and expressed as
/// RelativeMotion's body-frame covariance of the motion `T_prev_curr` (previous <- current rig).
Matrix6d bodyCovarianceSincePrevious(const Matrix6d& covariance_ref, const Eigen::Isometry3d& T_prev_ref,
                                     const Eigen::Isometry3d& T_prev_curr, const Eigen::Isometry3d& T_B_R0) {
  // Left perturbation in the reference camera -> in the previous camera: the adjoint of T_prev_ref.
  Matrix6d Ad = Matrix6d::Zero();
  Ad.topLeftCorner<3, 3>() = T_prev_ref.rotation();
  Ad.bottomRightCorner<3, 3>() = T_prev_ref.rotation();
  Ad.bottomLeftCorner<3, 3>() = se3::skew(T_prev_ref.translation()) * T_prev_ref.rotation();
  return imu::cameraToBodyMotionCovariance(Ad * covariance_ref * Ad.transpose(), T_prev_curr, T_B_R0);
}

/// A vision-only motion against the reference (keyframe or previous frame), as the inertial
/// estimator's measurement between the previous frame's body pose and the current one.
/// `T_prev_ref` (rig frames) carries it from the reference to the previous frame; its error is
/// the keyframe's shared one, so frames through one keyframe telescope and the filter, which
/// takes each increment with the whole covariance, errs on the cautious side.
imu::RelativeMotion visionMotionSincePrevious(const MotionRefinementResult& vision, const Eigen::Isometry3d& T_prev_ref,
                                              const Eigen::Isometry3d& T_B_R0) {
  const Eigen::Isometry3d T_prev_curr = T_prev_ref * vision.T_prev_curr;
  imu::RelativeMotion z;
  const Eigen::Isometry3d T_B = T_B_R0 * T_prev_curr * T_B_R0.inverse();
  z.R_prev_curr = T_B.rotation();
  z.p_prev_curr = T_B.translation();
  z.covariance = bodyCovarianceSincePrevious(vision.covariance, T_prev_ref, T_prev_curr, T_B_R0);
  return z;
}

/// Keyframe tracking: the rotation a gyro-bias error of covariance `Pbg_B` [body] turns over
/// the keyframe's span before this interval (this interval's is in the prediction), in the rig.
Eigen::Matrix3d keyframeBiasCovariance(const Eigen::Matrix3d& Pbg_B, const Eigen::Matrix3d& R_B_R0, double dt_s,
                                       double dt_ref_s) {
  const double span2 = std::max(0.0, dt_ref_s * dt_ref_s - dt_s * dt_s);
  return R_B_R0.transpose() * Pbg_B * R_B_R0 * span2;
}

/// A re-observation's covariance update (GlobalCorrection: scale, then position variance added).
void shrinkCovariance(Matrix6d& P, double scale, double added_position_variance_m2) {
  P *= scale;
  P.bottomRightCorner<3, 3>() += Eigen::Matrix3d::Identity() * added_position_variance_m2;
}

/// Local ICP's model: `index` rebuilt over the points of `features` (`scratch` holds the
/// positions on the way, kept so that only the tree's own nodes allocate).
void buildPointIndex(const matching::StereoFeatures& features, std::vector<Eigen::Vector3f>& scratch,
                     icp::PointCloudIndex& index) {
  scratch.clear();
  reserveWithHeadroom(scratch, features.points.size());
  for (const auto& sp : features.points) scratch.push_back(sp.p_R0);
  index.build(scratch);
}

/// Why no RANSAC attempt gave a visual estimate: the first stage that left fewer candidates
/// than the smallest accepted inlier count `need` (the rescue's when it runs), else RANSAC.
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
      }()) {}

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
    shrinkCovariance(pose_covariance_, c.covariance_scale, c.added_position_variance_m2);
    if (keyframe_) shrinkCovariance(keyframe_->pose_covariance, c.covariance_scale, c.added_position_variance_m2);
    ++deferred_revisits_;
  }
}

OdometryResult Odometry::process(const StereoFrame& frame, std::span<const ImuSample> imu) {
  // Into the buffers of an earlier frame, which track() hands back (no allocation).
  frontend_.process(frame, controller_.threshold(), now_, frontend_ws_, spare_frame_);
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
  if (params_.global_link) {
    // Corrections of earlier frames first, so this frame is predicted from corrected poses.
    GlobalCorrection c;
    while (params_.global_link->poll(c)) applyGlobalCorrection(c);
  }
  pending_request_.reset();
  StageTimer timer(now_);
  OdometryResult r;
  r.t_ns = frame.t_ns;
  r.seq = frame.seq;
  r.times = frame.times;
  r.quality.features_left = static_cast<int>(frame.left.keypoints.size());
  r.quality.features_right = static_cast<int>(frame.right.keypoints.size());
  r.quality.stereo_matches = static_cast<int>(frame.stereo.points.size());
  r.quality.stereo_completed = frame.stereo.completed;
  r.quality.detector_threshold = frame.detector_threshold;

  // Keep IMU samples across calls so integration can interpolate at the frame boundaries.
  for (const ImuSample& s : imu)
    if (imu_buffer_.empty() || s.t_ns > imu_buffer_.back().t_ns) imu_buffer_.push_back(s);

  const camera::RectifiedRig& rig = frontend_.rig();
  const Eigen::Isometry3d T_B_R0 = rig.T_B_R0;

  if (!initialised_) {
    initialise(frame, imu_buffer_);
    publishState(r);
    r.source = PoseSource::kInit;
    // Paper III-B: a proportional controller holds the feature count (and, in snow, the stereo
    // matches) for the next frame; nothing tracked yet, so no inliers.
    updateController(r.quality.features_left, descriptorStereoMatches(r.quality), -1);
    const Eigen::Isometry3d T_W_R0 = state_.T_W_B * T_B_R0;
    if (params_.mode == Mode::kGlobal && deferred_) {
      makeGlobalRequest(frame, T_W_R0, r, true);
    } else if (params_.mode == Mode::kGlobal) {
      refiner_.insertKeyframe(frame.seq, frame.t_ns, T_W_R0, [&] {
        std::vector<Eigen::Vector3f> p;
        for (const auto& sp : frame.stereo.points) p.push_back(sp.p_R0);
        return p;
      }(), frame.stereo, pose_covariance_.bottomRightCorner<3, 3>().trace(), true);
    }
    if (params_.keyframe_tracking) newKeyframe(frame, T_W_R0, r.t_ns);
    previous_ = PreviousFrame{std::move(frame), T_W_R0, r.t_ns};
    r.times.total_ms = r.times.rectify_ms + r.times.features_ms + r.times.stereo_ms + timer.total_ms();
    return r;
  }

  // --- III-A: the inertial estimator propagated through this interval; its motion since the
  // previous frame, with its covariance (gyro noise, velocity, tilt and bias uncertainty as the
  // filter holds them), is the prediction.
  const double dt_s = 1e-9 * static_cast<double>(frame.t_ns - state_.t_ns);
  const bool have_imu = filter_.started() && imu_buffer_.size() >= 2 && imu_buffer_.back().t_ns >= state_.t_ns;
  if (have_imu && filter_stale_) {
    // The IMU came back after an outage (or after a start without samples): the filter
    // starts again from the visual state, its inertial states at their start-up spread.
    filter_.startFrom(state_);
    filter_stale_ = false;
  }
  if (filter_.started() && !have_imu) filter_stale_ = true;
  imu::RelativeMotion inertial_motion;  // body, previous <- current
  Eigen::Isometry3d T_prev_curr_pred;   // rectified left camera, previous <- current
  Matrix6d pred_cov;
  if (have_imu) {
    filter_.propagate(imu_buffer_, frame.t_ns);
    inertial_motion = filter_.predictedMotion();
    T_prev_curr_pred = orthonormalized(T_B_R0.inverse() * bodyMotion(inertial_motion) * T_B_R0);
    pred_cov = imu::bodyToCameraMotionCovariance(inertial_motion.covariance, T_prev_curr_pred, T_B_R0);
  } else {
    // No IMU (KITTI, an IMU outage, or vision-only by choice): constant-velocity prediction,
    // loosely trusted.
    const double scale = last_dt_s_ > 0 ? dt_s / last_dt_s_ : 1.0;
    T_prev_curr_pred = se3::expSE3(se3::logSE3(last_motion_) * scale);
    pred_cov = Matrix6d::Zero();
    pred_cov.diagonal() << 4e-4, 4e-4, 4e-4, 0.01, 0.01, 0.01;
  }
  // Drop what is no longer needed (keeping one sample before the frame for interpolation).
  while (imu_buffer_.size() > 2 && imu_buffer_[1].t_ns <= frame.t_ns) imu_buffer_.erase(imu_buffer_.begin());

  // --- III-C: inter-frame matching pruned by the prediction, against the reference frame:
  // the keyframe (keyframe_tracking) or the previous frame. From here on
  // "prev" in a name means that reference.
  const PreviousFrame& prev = *previous_;
  const matching::StereoFeatures* ref_features = &prev.features.stereo;
  Eigen::Isometry3d T_W_ref = prev.T_W_R0;
  Eigen::Isometry3d T_ref_curr_pred = T_prev_curr_pred;
  Eigen::Matrix3d R_ref_curr_gyro = T_prev_curr_pred.rotation();  // the gyro alone since the reference
  Eigen::Matrix3d ref_gyro_cov = Eigen::Matrix3d::Zero();           // its noise before this interval
  double dt_ref_s = dt_s;
  const bool kf_usable = keyframe_.has_value() && params_.keyframe_tracking;
  bool on_keyframe = kf_usable;
  if (on_keyframe) {
    ref_features = &keyframe_->features;
    T_W_ref = keyframe_->T_W_R0;
    T_ref_curr_pred = orthonormalized(T_W_ref.inverse() * prev.T_W_R0 * T_prev_curr_pred);
    R_ref_curr_gyro = keyframe_->R_kf_prev_gyro * T_prev_curr_pred.rotation();
    ref_gyro_cov = keyframe_->gyro_covariance;
    dt_ref_s = 1e-9 * static_cast<double>(frame.t_ns - keyframe_->t_ns);
  }
  std::vector<matching::TemporalMatch>& temporal = work_.temporal;
  matching::matchTemporal(*ref_features, frame.stereo, rig, T_ref_curr_pred, pred_cov, params_.temporal,
                          work_.temporal_ws, temporal);
  r.times.temporal_ms = timer.lap_ms();

  // --- III-C: quadrifocal tensor of the two pairs, RANSAC + refinement.
  std::vector<geometry::QuadMatch>& quads = work_.quads;
  std::vector<uint32_t>& quad_reference = work_.quad_reference;
  const auto toQuads = [&] {
    quads.clear();
    quad_reference.clear();
    // Room for the guided tracks too (at most one per reference point), so none reallocates.
    reserveWithHeadroom(quads, temporal.size() + ref_features->points.size());
    reserveWithHeadroom(quad_reference, temporal.size() + ref_features->points.size());
    for (const auto& m : temporal) {
      const auto& a = ref_features->points[static_cast<std::size_t>(m.prev)];
      const auto& b = frame.stereo.points[static_cast<std::size_t>(m.curr)];
      quads.push_back(geometry::QuadMatch{a.uv_left, a.uv_right, b.uv_left, b.uv_right});
      quad_reference.push_back(static_cast<uint32_t>(m.prev));
    }
  };
  toQuads();
  geometry::RansacResult& ransac = work_.ransac;
  ransac_.estimate(quads, T_ref_curr_pred, rng_, ransac);
  bool vision_ok = ransac.status == geometry::RansacStatus::kOk &&
                   static_cast<int>(ransac.inliers.size()) >= params_.min_inliers && finitePose(ransac.T_prev_curr);
  r.times.tensor_ms = timer.lap_ms();
  if (!vision_ok && on_keyframe && keyframe_->t_ns != prev.t_ns) {
    // The keyframe is lost (a turn, texture gone): the previous frame is the reference again.
    on_keyframe = false;
    ref_features = &prev.features.stereo;
    T_W_ref = prev.T_W_R0;
    T_ref_curr_pred = T_prev_curr_pred;
    R_ref_curr_gyro = T_prev_curr_pred.rotation();
    ref_gyro_cov.setZero();
    dt_ref_s = dt_s;
    matching::matchTemporal(*ref_features, frame.stereo, rig, T_ref_curr_pred, pred_cov, params_.temporal,
                            work_.temporal_ws, temporal);
    r.times.temporal_ms += timer.lap_ms();
    toQuads();
    ransac_.estimate(quads, T_ref_curr_pred, rng_, ransac);
    vision_ok = ransac.status == geometry::RansacStatus::kOk &&
                static_cast<int>(ransac.inliers.size()) >= params_.min_inliers && finitePose(ransac.T_prev_curr);
  }
  r.quality.temporal_matches = static_cast<int>(temporal.size());
  // The feature controller's inlier target reads frames tracked against the previous frame
  // only: their overlap is the one the frame rate gives. Against an ageing keyframe (10 Hz) the
  // inliers fall by design until a new keyframe is made; chasing them would add features on
  // every frame for the overlap the keyframe policy gives up anyway.
  const bool reference_is_previous = !on_keyframe || keyframe_->t_ns == prev.t_ns;
  bool rescued = false;  // `ransac` came from the rescue RANSAC (its threshold)
  const auto rescue = [&] {
    if (static_cast<int>(quads.size()) < params_.rescue_min_inliers) return false;
    geometry::RansacResult second = rescue_ransac_.estimate(quads, T_ref_curr_pred, rng_);
    if (second.status != geometry::RansacStatus::kOk ||
        static_cast<int>(second.inliers.size()) < params_.rescue_min_inliers || !finitePose(second.T_prev_curr))
      return false;
    ransac = std::move(second);
    rescued = true;
    return true;
  };
  if (!vision_ok && params_.rescue_inlier_threshold_px > 0 && shed_.rescue_retries) {
    vision_ok = rescue();
    if (!vision_ok && params_.temporal.use_prediction) {
      // After a lost frame the coasting prediction can be too wrong for its windows (a fast
      // turn, a velocity gone stale): search the whole image once, so tracking comes back.
      matching::TemporalMatchParams whole = params_.temporal;
      whole.use_prediction = false;
      matching::matchTemporal(*ref_features, frame.stereo, rig, T_ref_curr_pred, pred_cov, whole, work_.temporal_ws,
                              temporal);
      toQuads();
      vision_ok = rescue();
    }
  }
  RefusalFigures refusal;
  if (!vision_ok) {
    const int need = params_.rescue_inlier_threshold_px > 0 ? std::min(params_.min_inliers, params_.rescue_min_inliers)
                                                            : params_.min_inliers;
    refusal = visionRefusal(frame.stereo.points.size(), temporal.size(), ransac, params_.min_inliers, need);
  }
  if (vision_ok && params_.patch_refinement) {
    r.times.tensor_ms += timer.lap_ms();
    const cv::Mat& ref_left = on_keyframe ? keyframe_->left_image : prev.features.left_image;
    const cv::Mat& ref_right = on_keyframe ? keyframe_->right_image : prev.features.right_image;
    ReferenceAlignments* cache = nullptr;
    if (on_keyframe) {
      if (!work_.keyframe_alignments.holds(keyframe_->id))
        work_.keyframe_alignments.reset(keyframe_->id, ref_features->points.size());
      cache = &work_.keyframe_alignments;
    }
    if (params_.patch_reselect && static_cast<int>(ransac.inliers.size()) >= params_.patch_reselect_min_inliers) {
      std::vector<uint32_t>& all = work_.patch_indices;
      resizeWithHeadroom(all, quads.size());
      std::iota(all.begin(), all.end(), 0u);
      refinePatches(*ref_features, ref_left, ref_right, frame, temporal, ransac.T_prev_curr, all, cache, quads);
      // The reference points descriptor matching missed, looked for where the motion puts them
      // (guided_tracks.hpp); judged below with the rest. They sit after `temporal`'s quads.
      r.quality.guided_tracks =
          trackUnmatched(*ref_features, ref_left, ref_right, frame.left_image, frame.right_image, rig,
                         ransac.T_prev_curr, temporal, params_.patch, params_.guided_tracks, cache, work_.guided_used,
                         quads);
      for (std::size_t i = 0; i < work_.guided_used.size(); ++i)
        if (work_.guided_used[i] == 2) quad_reference.push_back(static_cast<uint32_t>(i));
      // The same RANSAC (threshold) that found the motion judges the refined pixels. If too
      // few pass, the first selection stands: its inliers were refined just as before.
      geometry::RansacResult& again = work_.reselected;
      again.T_prev_curr = ransac.T_prev_curr;
      again.iterations = ransac.iterations;
      (rescued ? rescue_ransac_ : ransac_).reselect(quads, again);
      const int need = rescued ? params_.rescue_min_inliers : params_.min_inliers;
      if (again.status == geometry::RansacStatus::kOk && static_cast<int>(again.inliers.size()) >= need &&
          finitePose(again.T_prev_curr))
        std::swap(ransac, again);
    } else {
      refinePatches(*ref_features, ref_left, ref_right, frame, temporal, ransac.T_prev_curr, ransac.inliers, cache,
                    quads);
    }
    r.times.patch_ms = timer.lap_ms();
    r.times.tensor_ms += r.times.patch_ms;
  }

  r.quality.ransac_inliers = static_cast<int>(ransac.inliers.size());
  Eigen::Isometry3d T_prev_curr = vision_ok ? ransac.T_prev_curr : T_ref_curr_pred;
  Matrix6d rel_cov = vision_ok ? Matrix6d(ransac.covariance) : pred_cov;
  bool sensitivity_ok = false;  // work_.sensitivity belongs to rel_cov
  if (vision_ok && params_.use_rotation_prior) {
    // IMU-aided refinement: the gyro's rotation as a prior removes the pitch/surge ambiguity
    // of a flat floor (see motion_refinement.hpp).
    RotationPrior prior;
    prior.valid = have_imu;
    prior.R_prev_curr = R_ref_curr_gyro;
    // Relative rotation noise only: the absolute attitude uncertainty carried in the start
    // covariance passes through the short propagation unchanged (F ~ I) and is removed.
    // Since a keyframe, the gyro's white noise adds up per interval, its bias error with time.
    prior.covariance = ref_gyro_cov + pred_cov.topLeftCorner<3, 3>() +
                       keyframeBiasCovariance(filter_.covariance().block<3, 3>(imu::kEsBg, imu::kEsBg),
                                              T_B_R0.rotation(), dt_s, dt_ref_s);
    const MotionRefinementResult refined =
        refineMotion(rig, quads, ransac.inliers, T_prev_curr, prior, params_.refinement, work_.refinement,
                     &work_.sensitivity);
    if (refined.ok) {
      T_prev_curr = refined.T_prev_curr;
      rel_cov = refined.covariance;
      sensitivity_ok = true;
    }
  }
  // The inertial estimator's measurement is the four-view motion without the gyro prior: the
  // prior-refined one would feed the gyro back to the filter as if vision had seen it.
  std::optional<MotionRefinementResult> vision_alone;
  if (vision_ok && have_imu) {
    vision_alone = refineMotion(rig, quads, ransac.inliers, ransac.T_prev_curr, RotationPrior{}, params_.refinement,
                                work_.refinement);
    if (!vision_alone->ok) vision_alone.reset();
  }
  Eigen::Isometry3d T_W_R0 = T_W_ref * T_prev_curr;
  // Tensor stage = RANSAC (and its fallbacks) plus the four-view refinements (paper III-C).
  r.times.tensor_ms += timer.lap_ms();

  // --- III-D/E: ICP against the previous frame (local) or the map near the prediction (global).
  std::vector<Eigen::Vector3f>& data = work_.cloud;
  data.clear();
  reserveWithHeadroom(data, frame.stereo.points.size());
  for (const auto& sp : frame.stereo.points) data.push_back(sp.p_R0);
  // Global mode: how far the map moved the frame off its odometry. A correction is not
  // motion, so it stays out of the speed check and the velocity.
  Eigen::Vector3d map_shift_W = Eigen::Vector3d::Zero();
  // Inline global step: the map's correction of this frame as a delta in W, and the
  // re-observation's covariance update; both reach the keyframe once the frame is accepted.
  std::optional<Eigen::Isometry3d> map_delta_W;
  std::optional<GlobalCorrection> inline_revisit;
  if (vision_ok) {
    std::vector<std::pair<int, int>>& seeds = work_.seeds;
    seeds.clear();
    reserveWithHeadroom(seeds, ransac.inliers.size());
    if (params_.mode == Mode::kLocal) {
      // The keyframe's tree was built with it; only a frame tracked against the previous frame
      // (no keyframe, or the keyframe lost) builds one, and that allocates (nanoflann's pool).
      const icp::PointCloudIndex* index = on_keyframe ? &keyframe_->model_index : nullptr;
      if (!index || index->size() != ref_features->points.size()) {
        buildPointIndex(*ref_features, work_.model, work_.previous_index);
        index = &work_.previous_index;
      }
      const std::vector<Eigen::Vector3f>& model = index->points();
      for (uint32_t i : ransac.inliers)  // guided tracks (past `temporal`) have no current stereo point
        if (i < temporal.size()) seeds.emplace_back(temporal[i].curr, temporal[i].prev);
      const icp::IcpResult icp = icp::alignIcp(data, model, *index, seeds, T_prev_curr, params_.icp, work_.icp);
      r.quality.icp_iterations = icp.iterations;
      r.quality.icp_inliers = icp.inliers;
      r.quality.icp_rms_m = icp.rms_m;
      r.quality.model_points = static_cast<int>(model.size());
      if (icp.status == icp::IcpStatus::kOk && params_.final_stage == FinalStage::kIcp && finitePose(icp.T_model_data)) {
        T_prev_curr = icp.T_model_data;
        T_W_R0 = T_W_ref * T_prev_curr;
      }
    } else if (!deferred_) {
      // The global step inline (GlobalRefiner::correct); keyframes are inserted below, once
      // the frame passed the speed check.
      const GlobalCorrection g =
          refiner_.correct(frame.stereo, data, frame.seq, frame.t_ns, T_W_R0, pose_covariance_, rng_);
      if (g.changed()) {
        map_shift_W = g.T_W_R0.translation() - T_W_R0.translation();
        map_delta_W = g.T_W_R0 * T_W_R0.inverse();
        T_W_R0 = g.T_W_R0;
        T_prev_curr = prev.T_W_R0.inverse() * T_W_R0;
      }
      if (g.revisit_used) inline_revisit = g;
      r.quality.model_points = g.model_points;
      r.quality.map_refined = g.changed();
      if (g.icp_ran) {
        r.quality.icp_iterations = g.icp_iterations;
        r.quality.icp_inliers = g.icp_inliers;
        r.quality.icp_rms_m = g.icp_rms_m;
      }
    }
  }
  r.times.icp_ms = timer.lap_ms();

  T_W_R0 = orthonormalized(T_W_R0);
  Eigen::Isometry3d T_W_B = orthonormalized(T_W_R0 * T_B_R0.inverse());
  if (vision_ok && dt_s > 0) {
    // Faster than the rig ever moves (its profile, with a margin): a wrong solution.
    const double speed_m_s = (T_W_B.translation() - map_shift_W - state_.T_W_B.translation()).norm() / dt_s;
    const double limit_m_s = params_.rig.max_speed_m_s * params_.speed_margin;
    if (speed_m_s > limit_m_s) {
      vision_ok = false;  // a jump: refuse it rather than publish it
      refusal = {Refusal::kSpeed, speed_m_s, limit_m_s};
    }
  }

  // The inertial estimator takes the vision-only motion since the previous frame, through its
  // chi-square gate; a refused motion is not used for the pose either (the frame coasts,
  // flagged). Against a keyframe older than a coasted previous frame the motion would carry
  // that frame's prediction into the measurement: the filter then only moves its clone on.
  const bool reference_measured = !previous_coasted_ || !on_keyframe || keyframe_->t_ns == prev.t_ns;
  if (have_imu) {
    if (vision_ok && vision_alone && reference_measured) {
      const imu::RelativeMotion z = visionMotionSincePrevious(*vision_alone, prev.T_W_R0.inverse() * T_W_ref, T_B_R0);
      double d2 = 0;
      const imu::UpdateOutcome outcome = filter_.update(z, &d2);
      r.quality.inertial_mahalanobis2 = d2;
      if (outcome == imu::UpdateOutcome::kRefused) {
        vision_ok = false;
        refusal = {Refusal::kInertialGate, d2, params_.inertial.gate_chi2};
      }
      r.quality.imu_fault = outcome == imu::UpdateOutcome::kImuFault;
    }
  }

  if (vision_ok) {
    // The velocity: the filter's, turned from its world into the chain's (they share the
    // start-up frame and part only by the chain's rotation drift); without an IMU the visual
    // step's. A map correction is not motion: it only turns the velocity with the frame.
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    if (have_imu) {
      const NavState f = filter_.state();
      v = T_W_B.rotation() * f.T_W_B.rotation().transpose() * f.v_W;
    } else if (dt_s > 1e-6) {
      v = (T_W_B.translation() - map_shift_W - state_.T_W_B.translation()) / dt_s;
    }
    if (map_delta_W) v = map_delta_W->linear() * v;
    state_.T_W_B = T_W_B;
    state_.v_W = v;
    if (on_keyframe) pose_covariance_ = keyframe_->pose_covariance;
    // The reference's rotation error turns this step, and the heading random-walks with the
    // gyro-bias error since the reference (chain_covariance.hpp: the global search's sigma).
    composeChainCovariance(pose_covariance_, rel_cov, T_W_ref.rotation(),
                           T_W_R0.translation() - map_shift_W - T_W_ref.translation(),
                           headingVariance(params_.heading_bias_error_rad_s, params_.heading_bias_time_constant_s,
                                           dt_ref_s));
    // The keyframe this frame was tracked against moves with it (the same delta in W as
    // applyGlobalCorrection composes), so the frames tracked against it next keep the map's
    // correction instead of falling back to where the odometry alone put them; its
    // uncertainty shrinks with the frame's when the map bounded the drift (III-D).
    if (on_keyframe && map_delta_W) keyframe_->T_W_R0 = orthonormalized(*map_delta_W * keyframe_->T_W_R0);
    if (inline_revisit) {
      shrinkCovariance(pose_covariance_, inline_revisit->covariance_scale, inline_revisit->added_position_variance_m2);
      if (on_keyframe)
        shrinkCovariance(keyframe_->pose_covariance, inline_revisit->covariance_scale,
                         inline_revisit->added_position_variance_m2);
    }
    fix_pose_covariance_ = pose_covariance_;
    r.source = PoseSource::kVision;
  } else if (have_imu) {
    // Vision refused: coast on the filter's propagation from the previous frame, flagged. The
    // covariance is the last fix's plus what the filter's grew by since: its velocity, tilt and
    // bias errors with their correlations make dead-reckoning error grow with time squared.
    T_W_B = orthonormalized(prev.T_W_R0 * T_B_R0.inverse() * bodyMotion(inertial_motion));
    T_W_R0 = T_W_B * T_B_R0;
    const NavState f = filter_.state();
    state_.T_W_B = T_W_B;
    state_.v_W = T_W_B.rotation() * f.T_W_B.rotation().transpose() * f.v_W;
    pose_covariance_ = fix_pose_covariance_ + positivePart(filter_.poseCovarianceW() - fix_filter_covariance_);
    r.source = PoseSource::kImuOnly;
    r.coasting = CoastingCorrection::kInertial;
    r.refusal = refusal;
  } else {
    // No IMU: the constant-velocity prediction, its loose covariance composed onto the chain's.
    T_W_R0 = orthonormalized(prev.T_W_R0 * T_prev_curr_pred);
    T_W_B = orthonormalized(T_W_R0 * T_B_R0.inverse());
    state_.T_W_B = T_W_B;
    composeChainCovariance(pose_covariance_, pred_cov, prev.T_W_R0.rotation(),
                           T_W_R0.translation() - prev.T_W_R0.translation(), 0.0);
    r.source = PoseSource::kImuOnly;
    r.coasting = CoastingCorrection::kNoImu;
    r.refusal = refusal;
  }
  if (have_imu) {
    const NavState f = filter_.state();
    state_.gyro_bias_rad_s = f.gyro_bias_rad_s;
    state_.accel_bias_m_s2 = f.accel_bias_m_s2;
    r.gyro_bias_sigma_rad_s = filter_.covariance().block<3, 3>(imu::kEsBg, imu::kEsBg).diagonal().cwiseSqrt();
    r.accel_bias_sigma_m_s2 = filter_.covariance().block<3, 3>(imu::kEsBa, imu::kEsBa).diagonal().cwiseSqrt();
    // A visual fix anchors the filter's position; coasting frames keep what accrues since.
    filter_.clonePose(r.source == PoseSource::kVision);
    if (r.source == PoseSource::kVision) fix_filter_covariance_ = filter_.poseCovarianceW();
  }
  state_.t_ns = frame.t_ns;
  if (!finitePose(state_.T_W_B) || !state_.v_W.allFinite()) {
    // Never let a NaN leave core: hold the last finite state.
    state_.T_W_B = prev.T_W_R0 * T_B_R0.inverse();
    state_.v_W.setZero();
    T_W_R0 = prev.T_W_R0;
    r.source = PoseSource::kImuOnly;
    r.coasting = CoastingCorrection::kHeld;
    r.refusal = {Refusal::kNonFinite, 0, 0};
    if (filter_.started()) filter_stale_ = true;  // restarts from the held state
  }
  // What the published increment claims: the motion it was chained from is the visual one
  // (rel_cov, also when ICP placed the frame) only on a visual frame whose reference reaches the
  // previous frame through measured poses, and that no map correction moved since either was
  // published.
  // The refined motion's claim takes the pixel noise its residuals show (work_.sensitivity);
  // against a keyframe the previous frame was also placed from, their shared error cancels
  // (increment_covariance.hpp).
  const bool published_visual = r.source == PoseSource::kVision && !map_delta_W;
  if (published_visual && reference_measured && !moved_since_published_) {
    std::optional<Matrix6d> claim;
    if (sensitivity_ok) claim = work_.sensitivity.covariance;
    if (on_keyframe && sensitivity_ok && keyframe_->t_ns != prev.t_ns)
      if (const auto shared = keyframe_increment_.increment(keyframe_->id, prev.t_ns, work_.sensitivity, quad_reference))
        claim = shared;
    r.increment_covariance = bodyCovarianceSincePrevious(claim ? *claim : rel_cov, prev.T_W_R0.inverse() * T_W_ref,
                                                         prev.T_W_R0.inverse() * T_W_R0, T_B_R0);
  }
  if (published_visual && on_keyframe && sensitivity_ok)
    keyframe_increment_.record(keyframe_->id, frame.t_ns, work_.sensitivity, quad_reference,
                               ref_features->points.size());
  else
    keyframe_increment_.forget();
  moved_since_published_ = false;
  previous_coasted_ = r.source != PoseSource::kVision;
  last_motion_ = prev.T_W_R0.inverse() * T_W_R0;
  last_dt_s_ = dt_s;
  publishState(r);
  if (params_.mode == Mode::kGlobal && r.source == PoseSource::kVision && shed_.global_step) {
    if (deferred_) {
      makeGlobalRequest(frame, T_W_R0, r, false);
    } else {
      // The cloud is kept for the next frame: the map gets a copy only when it stores one.
      refiner_.insertKeyframe(frame.seq, frame.t_ns, T_W_R0,
                              refiner_.frameMap().wantsKeyframe(T_W_R0) ? data : std::vector<Eigen::Vector3f>{},
                              frame.stereo, pose_covariance_.bottomRightCorner<3, 3>().trace(), false);
    }
  }
  if (kf_usable) {
    // Keep the keyframe while it still overlaps well with the frames; else this one takes over.
    const int inliers = r.quality.ransac_inliers;
    if (on_keyframe && r.source == PoseSource::kVision && keyframe_->first_inliers == 0)
      keyframe_->first_inliers = inliers;
    const bool keep =
        on_keyframe && r.source == PoseSource::kVision && inliers >= params_.keyframe_min_inliers &&
        inliers >= params_.keyframe_min_inlier_ratio * keyframe_->first_inliers &&
        (keyframe_->T_W_R0.inverse() * T_W_R0).translation().norm() <= params_.keyframe_max_distance_m;
    if (keep) {
      keyframe_->R_kf_prev_gyro = R_ref_curr_gyro;
      keyframe_->gyro_covariance = ref_gyro_cov + pred_cov.topLeftCorner<3, 3>();
    } else {
      newKeyframe(frame, T_W_R0, r.t_ns);
    }
  }
  // The outgoing previous frame's buffers go back to the caller's FrameFeatures.
  std::swap(previous_->features, frame);
  previous_->T_W_R0 = T_W_R0;
  previous_->t_ns = r.t_ns;
  r.times.total_ms = r.times.rectify_ms + r.times.features_ms + r.times.stereo_ms + timer.total_ms();
  // Paper III-B's controller for the next frame, also holding the inliers against the previous
  // frame (target_inliers: the overlap decides how many features become inliers).
  updateController(r.quality.features_left, descriptorStereoMatches(r.quality),
                   reference_is_previous ? r.quality.ransac_inliers : -1);
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

void Odometry::newKeyframe(const FrameFeatures& frame, const Eigen::Isometry3d& T_W_R0, int64_t t_ns) {
  const matching::StereoFeatures& features = frame.stereo;
  // Its own copies (the keyframe outlives the frame whose buffers the frontend reuses), into
  // the outgoing keyframe's buffers: at 1 Hz every frame is a keyframe, and fresh copies would
  // allocate images and points per frame. The descriptors' Mat is reallocated when
  // the count changes; the tree's nodes always are (nanoflann's pool).
  Keyframe k;
  if (keyframe_) {
    k.left_image = std::move(keyframe_->left_image);
    k.right_image = std::move(keyframe_->right_image);
    k.features = std::move(keyframe_->features);
    k.model_index = std::move(keyframe_->model_index);
  }
  if (params_.patch_refinement) {
    frame.left_image.copyTo(k.left_image);
    frame.right_image.copyTo(k.right_image);
  }
  k.features.points.assign(features.points.begin(), features.points.end());
  k.features.laplacian_sign.assign(features.laplacian_sign.begin(), features.laplacian_sign.end());
  features.descriptors.copyTo(k.features.descriptors);
  if (params_.mode == Mode::kLocal) buildPointIndex(features, work_.model, k.model_index);
  k.T_W_R0 = T_W_R0;
  k.t_ns = t_ns;
  k.id = ++keyframes_made_;
  k.pose_covariance = pose_covariance_;
  keyframe_ = std::move(k);
}

void Odometry::refinePatches(const matching::StereoFeatures& ref_features, const cv::Mat& ref_left,
                             const cv::Mat& ref_right, const FrameFeatures& frame,
                             const std::vector<matching::TemporalMatch>& temporal,
                             const Eigen::Isometry3d& T_ref_curr, std::span<const uint32_t> indices,
                             ReferenceAlignments* cache, std::vector<geometry::QuadMatch>& quads) const {
  if (ref_left.empty() || ref_right.empty() || frame.left_image.empty() || frame.right_image.empty()) return;
  // A reference offset d appears in the current image turned by the motion's roll about the
  // optical axis and scaled by the depth ratio (a near-nadir view of a near-flat floor).
  const Eigen::Matrix2f turn = matching::inPlaneTurn(T_ref_curr.rotation());
  for (const uint32_t i : indices) {
    if (i >= quads.size() || i >= temporal.size()) continue;
    geometry::QuadMatch& q = quads[i];
    const auto& a = ref_features.points[static_cast<std::size_t>(temporal[i].prev)];
    const auto& b = frame.stereo.points[static_cast<std::size_t>(temporal[i].curr)];
    const float scale = b.p_R0.z() > 0 && a.p_R0.z() > 0 ? a.p_R0.z() / b.p_R0.z() : 1.f;
    const Eigen::Matrix2f A = scale * turn;
    // q's reference pixels are point temporal[i].prev's (toQuads), as the cache assumes.
    const auto ref_index = static_cast<std::size_t>(temporal[i].prev);
    if (cache && cache->knownToFail(ref_index)) continue;
    const matching::PatchTemplate tmpl = matching::makePatchTemplate(ref_left, q.left_prev, params_.patch);
    Eigen::Vector2f uv_right_prev;
    if (!alignInReferenceRight(ref_index, tmpl, ref_right, q.right_prev, params_.patch, cache, uv_right_prev)) continue;
    const auto lc = matching::alignPatch(tmpl, frame.left_image, q.left_curr, A, params_.patch);
    if (!lc.ok) continue;
    const auto rc = matching::alignPatch(tmpl, frame.right_image, q.right_curr, A, params_.patch);
    // All three or none: a point half refined would mix two localisations of one feature.
    if (!rc.ok) continue;
    q.right_prev = uv_right_prev;
    q.left_curr = lc.uv;
    q.right_curr = rc.uv;
  }
}

std::size_t Odometry::mapMemoryBytes() const { return refiner_.memoryBytes(); }

void Odometry::publishState(OdometryResult& r) {
  r.T_W_B = state_.T_W_B;
  r.v_W = state_.v_W;
  r.covariance = pose_covariance_;
}

}  // namespace seavio::odometry
