#include "core/odometry/odometry.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/common/capacity.hpp"
#include "core/common/se3.hpp"
#include "core/common/stage_timer.hpp"
#include "core/odometry/chain_covariance.hpp"
#include "core/odometry/motion_refinement.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// The stereo matches the feature controller holds (target_stereo_matches): descriptor matches
/// only. Completed points come on top of the features it keeps; counted, they would make it
/// keep fewer features where completion helps most (snow at 10 Hz).
int descriptorStereoMatches(const Quality& q) { return q.stereo_matches - q.stereo_completed; }

/// Relative-motion covariance (rotation, translation) from the propagated error state.
Matrix6d relativeCovariance(const imu::Matrix9d& P) {
  Matrix6d C = Matrix6d::Zero();
  C.topLeftCorner<3, 3>() = P.topLeftCorner<3, 3>();
  C.bottomRightCorner<3, 3>() = P.block<3, 3>(6, 6);
  return C;
}

/// The inertial estimator's predicted motion as a body transform (previous <- current).
Eigen::Isometry3d bodyMotion(const imu::RelativeMotion& m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = m.R_prev_curr;
  T.translation() = m.p_prev_curr;
  return T;
}

/// A vision-only motion against the reference (keyframe or previous frame), as the inertial
/// estimator's measurement between the previous frame's body pose and the current one.
/// `T_prev_ref` (rig frames) carries it from the reference to the previous frame; its error is
/// the keyframe's shared one, so frames through one keyframe telescope and the filter, which
/// takes each increment with the whole covariance, errs on the cautious side.
imu::RelativeMotion visionMotionSincePrevious(const MotionRefinementResult& vision, const Eigen::Isometry3d& T_prev_ref,
                                              const Eigen::Isometry3d& T_B_R0) {
  // Left perturbation in the reference camera -> in the previous camera: the adjoint of T_prev_ref.
  Matrix6d Ad = Matrix6d::Zero();
  Ad.topLeftCorner<3, 3>() = T_prev_ref.rotation();
  Ad.bottomRightCorner<3, 3>() = T_prev_ref.rotation();
  Ad.bottomLeftCorner<3, 3>() = se3::skew(T_prev_ref.translation()) * T_prev_ref.rotation();
  const Eigen::Isometry3d T_prev_curr = T_prev_ref * vision.T_prev_curr;
  imu::RelativeMotion z;
  const Eigen::Isometry3d T_B = T_B_R0 * T_prev_curr * T_B_R0.inverse();
  z.R_prev_curr = T_B.rotation();
  z.p_prev_curr = T_B.translation();
  z.covariance = imu::cameraToBodyMotionCovariance(Ad * vision.covariance * Ad.transpose(), T_prev_curr, T_B_R0);
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

/// Adds a relative-motion covariance expressed in frame `R_W_a` to an absolute one in W.
void accumulate(Matrix6d& absolute, const Matrix6d& relative, const Eigen::Matrix3d& R_W_a) {
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = R_W_a;
  J.bottomRightCorner<3, 3>() = R_W_a;
  absolute += J * relative * J.transpose();
}

/// The visual gyro-bias residual (body frame) with its tilt part, perpendicular to gravity,
/// weighted by `tilt_weight` (OdometryParams::gyro_bias_vision_tilt_weight); the heading part,
/// about gravity, is what the visual rotation observes without the pitch/surge coupling.
Eigen::Vector3d weightTilt(const Eigen::Vector3d& residual_B, const Eigen::Matrix3d& R_W_B, double tilt_weight) {
  const Eigen::Vector3d z_B = R_W_B.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d heading_part = z_B * z_B.dot(residual_B);
  return heading_part + tilt_weight * (residual_B - heading_part);
}

/// The visual gyro-bias gain for one frame of `dt_s` (OdometryParams::gyro_bias_gain_interval_s):
/// gyro_bias_gain at its interval, scaled by sqrt(dt_s / interval) at others (the steady-state
/// Kalman gain with the bias walk per frame growing with dt_s and the residual's noise in rad/s
/// about rate-independent). At the 10 Hz of the short surveys the factor is exactly 1.
double gyroBiasGain(const OdometryParams& p, double dt_s) {
  if (p.gyro_bias_gain_interval_s <= 0 || dt_s <= 0) return p.gyro_bias_gain;
  return std::min(1.0, p.gyro_bias_gain * std::sqrt(dt_s / p.gyro_bias_gain_interval_s));
}

/// The mean specific force over an IMU interval, body frame, less the accelerometer bias.
Eigen::Vector3d meanSpecificForce(std::span<const ImuSample> interval, const Eigen::Vector3d& accel_bias_m_s2) {
  Eigen::Vector3d f_B = Eigen::Vector3d::Zero();
  for (const ImuSample& s : interval) f_B += s.accel_m_s2;
  return f_B / static_cast<double>(interval.size()) - accel_bias_m_s2;
}

/// The attitude halfway (on the geodesic) between two attitudes.
Eigen::Matrix3d midAttitude(const Eigen::Matrix3d& R_start, const Eigen::Matrix3d& R_end) {
  return R_start * se3::expSO3(0.5 * se3::logSO3(R_start.transpose() * R_end));
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
  g.keep_tilt = p.map_keeps_tilt && p.accel_bias_estimation;
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
        return e;
      }()),
      accel_bias_([&] {
        imu::AccelBiasParams a = params.accel_bias;
        a.bias_random_walk_m_s2_sqrt_s = imu_noise.accelerometer_random_walk;
        a.accel_noise_density = imu_noise.accelerometer_noise_density;
        return a;
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
  q.T_published_W = r.T_W_B * state_.T_W_B.inverse();
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
  gravity_bias_.reset();  // the chain moved: its windows no longer compare
  // The correction is a delta in W measured at an older frame; everything tracked since was
  // chained onto that frame's pose, so the same delta moves it too. A correction is not
  // motion: the velocity is only turned with the frame.
  state_.T_W_B = orthonormalized(delta * state_.T_W_B);
  state_.v_W = delta.linear() * state_.v_W;
  if (previous_) previous_->T_W_R0 = orthonormalized(delta * previous_->T_W_R0);
  // The next frame is tracked against the keyframe: it moves with the chain, or that frame
  // would be placed where the keyframe was before the correction and lose it.
  if (keyframe_) keyframe_->T_W_R0 = orthonormalized(delta * keyframe_->T_W_R0);
  // The velocity was turned mid-window: the accelerometer-bias window starts again, or turns
  // with it when the map only moves the heading (map_keeps_tilt).
  if (params_.map_keeps_tilt)
    accel_bias_.turnWindow(delta.linear());
  else
    accel_bias_.breakWindow();
  if (c.revisit_used) {
    shrinkCovariance(pose_covariance_, c.covariance_scale, c.added_position_variance_m2);
    if (keyframe_) shrinkCovariance(keyframe_->pose_covariance, c.covariance_scale, c.added_position_variance_m2);
    ++deferred_revisits_;
  }
}

float Odometry::descriptorSteeringDeg(int64_t t_ns, std::span<const ImuSample> imu) const {
  if (!params_.steer_upright_descriptors || !params_.features.surf.upright ||
      params_.features.type != features::DetectorType::kSurf)
    return 0.f;
  Eigen::Matrix3d R_W_B = Eigen::Matrix3d::Identity();
  if (initialised_) {
    // Degrees matter here, not micro-radians: a rectangle rule over the samples since the
    // last pose is enough (a pivot turn of 30 deg per frame is followed to a fraction of one).
    R_W_B = state_.T_W_B.linear();
    int64_t t_prev = state_.t_ns;
    const auto turn = [&](const ImuSample& s) {
      if (s.t_ns <= t_prev || s.t_ns > t_ns) return;
      const double dt_s = 1e-9 * static_cast<double>(s.t_ns - t_prev);
      R_W_B = R_W_B * se3::expSO3((s.gyro_rad_s - state_.gyro_bias_rad_s) * dt_s);
      t_prev = s.t_ns;
    };
    for (const ImuSample& s : imu_buffer_) turn(s);
    for (const ImuSample& s : imu) turn(s);
  }
  // W's x axis seen from the rectified left camera; both rectified cameras share its axes.
  const Eigen::Vector3d x_R0 = (R_W_B * frontend_.rig().T_B_R0.linear()).transpose() * Eigen::Vector3d::UnitX();
  // Looking along W's x axis (not a survey camera) there is no image direction to steer by.
  if (std::hypot(x_R0.x(), x_R0.y()) < 0.1) return 0.f;
  double deg = std::atan2(x_R0.y(), x_R0.x()) * 180.0 / M_PI;
  if (deg < 0) deg += 360.0;
  return deg >= 360.0 ? 0.f : static_cast<float>(deg);
}

OdometryResult Odometry::process(const StereoFrame& frame, std::span<const ImuSample> imu) {
  // Into the buffers of an earlier frame, which track() hands back (no allocation).
  frontend_.process(frame, controller_.threshold(), now_, frontend_ws_, spare_frame_,
                    descriptorSteeringDeg(frame.t_ns, imu));
  return track(std::move(spare_frame_), imu);
}

void Odometry::initialise(const FrameFeatures& frame, std::span<const ImuSample> imu) {
  state_ = NavState{};
  state_.t_ns = frame.t_ns;
  // Attitude from the accelerometer over the last second before the first frame (III-A).
  std::vector<ImuSample> recent;
  for (const ImuSample& s : imu)
    if (s.t_ns <= frame.t_ns && s.t_ns > frame.t_ns - 1'000'000'000) recent.push_back(s);
  if (const auto R = imu::attitudeFromAccelerometer(recent, 0.2)) state_.T_W_B.linear() = *R;
  // A vehicle that starts still hands us its gyro bias: without it the rotation prior would
  // carry the bias straight into the attitude.
  if (const auto bg = imu::gyroBiasAtRest(recent)) {
    state_.gyro_bias_rad_s = *bg;
    gyro_bias_sigma_rad_s_ = params_.gyro_bias_sigma_at_rest_rad_s;
  } else {
    gyro_bias_sigma_rad_s_ = params_.gyro_bias_sigma_unknown_rad_s;
  }
  state_covariance_ = imu::Matrix9d::Zero();
  state_covariance_.block<3, 3>(3, 3) =
      Eigen::Matrix3d::Identity() * params_.initial_velocity_sigma_m_s * params_.initial_velocity_sigma_m_s;
  pose_covariance_ = Matrix6d::Identity() * 1e-12;
  if (params_.prediction == Prediction::kImu) filter_.start(frame.t_ns, imu);
  accel_bias_.reset(state_.T_W_B.rotation(), imu::attitudeFromAccelerometer(recent, 0.2).has_value(),
                    params_.attitude_sigma_rad, gyro_bias_sigma_rad_s_);
  published_p_W_ = published_from_p_W_ = state_.T_W_B.translation();  // the start-up frame's anchor
  imu::GravityBiasObserverParams gravity;
  gravity.window_s = params_.gyro_bias_gravity_window_s;
  gravity.max_turn_rad = params_.gyro_bias_gravity_max_turn_rad;
  gravity.min_intervals = params_.gyro_bias_gravity_window_min_frames;
  gravity_bias_ = imu::GravityBiasObserver(gravity);
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

  // --- III-A: IMU dead reckoning from the last estimate to this frame.
  const double dt_s = 1e-9 * static_cast<double>(frame.t_ns - state_.t_ns);
  imu::Matrix9d start_cov = imu::Matrix9d::Zero();
  start_cov.block<3, 3>(3, 3) = state_covariance_.block<3, 3>(3, 3);
  start_cov.topLeftCorner<3, 3>() = state_covariance_.topLeftCorner<3, 3>();
  const bool have_imu = params_.prediction == Prediction::kImu && imu_buffer_.size() >= 2 &&
                        imu_buffer_.back().t_ns >= state_.t_ns;
  imu::ImuPropagation pred;
  Eigen::Isometry3d T_prev_curr_pred;  // rectified left camera, previous <- current
  Matrix6d pred_cov;
  // The inertial estimator's motion since the last frame, with its covariance (gyro noise,
  // velocity, tilt and bias uncertainty as the filter holds them), is the prediction.
  if (filter_.started()) filter_.propagate(imu_buffer_, frame.t_ns);
  if (have_imu) {
    pred = imu::propagate(state_, start_cov, imu_buffer_, frame.t_ns, imu_noise_);
    pred.state.T_W_B = orthonormalized(pred.state.T_W_B);
    const imu::RelativeMotion m = filter_.predictedMotion();
    T_prev_curr_pred = orthonormalized(T_B_R0.inverse() * bodyMotion(m) * T_B_R0);
    pred_cov = imu::bodyToCameraMotionCovariance(m.covariance, T_prev_curr_pred, T_B_R0);
  } else {
    // No IMU (KITTI, IMU outage, or vision-only by choice): constant-velocity prediction,
    // loosely trusted.
    pred.state = state_;
    pred.state.t_ns = frame.t_ns;
    const double scale = last_dt_s_ > 0 ? dt_s / last_dt_s_ : 1.0;
    T_prev_curr_pred = se3::expSE3(se3::logSE3(last_motion_) * scale);
    pred.state.T_W_B = state_.T_W_B * T_B_R0 * T_prev_curr_pred * T_B_R0.inverse();
    pred_cov = Matrix6d::Zero();
    pred_cov.diagonal() << 4e-4, 4e-4, 4e-4, 0.01, 0.01, 0.01;
  }
  // This interval's samples (for the still-start bias), then drop what is no longer needed
  // (keeping one sample before the frame for interpolation).
  std::vector<ImuSample>& interval = work_.interval;
  interval.clear();
  for (const ImuSample& s : imu_buffer_)
    if (s.t_ns > state_.t_ns && s.t_ns <= frame.t_ns) interval.push_back(s);
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
  const auto windowCentre = [&] { return T_ref_curr_pred; };
  std::vector<matching::TemporalMatch>& temporal = work_.temporal;
  matching::matchTemporal(*ref_features, frame.stereo, rig, windowCentre(), pred_cov, params_.temporal,
                          work_.temporal_ws, temporal);
  r.times.temporal_ms = timer.lap_ms();

  // --- III-C: quadrifocal tensor of the two pairs, RANSAC + refinement.
  std::vector<geometry::QuadMatch>& quads = work_.quads;
  const auto toQuads = [&] {
    quads.clear();
    // Room for the guided tracks too (at most one per reference point), so none reallocates.
    reserveWithHeadroom(quads, temporal.size() + ref_features->points.size());
    for (const auto& m : temporal) {
      const auto& a = ref_features->points[static_cast<std::size_t>(m.prev)];
      const auto& b = frame.stereo.points[static_cast<std::size_t>(m.curr)];
      quads.push_back(geometry::QuadMatch{a.uv_left, a.uv_right, b.uv_left, b.uv_right});
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
    matching::matchTemporal(*ref_features, frame.stereo, rig, windowCentre(), pred_cov, params_.temporal,
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
        refineMotion(rig, quads, ransac.inliers, T_prev_curr, prior, params_.refinement, work_.refinement);
    if (refined.ok) {
      T_prev_curr = refined.T_prev_curr;
      rel_cov = refined.covariance;
    }
  }
  // The gyro bias is learnt from vision alone: the four-view refinement without the prior.
  // RANSAC's own refinement holds the triangulated depths fixed, which over a flat floor tilts
  // its rotation along with the shortened translation (motion_refinement.hpp); a bias learnt
  // from that tilt pitched the attitude 19 mrad off within 36 m on a tuning survey (seed 5).
  std::optional<Eigen::Matrix3d> R_ref_curr_vision;
  // Per keyframe (gyro_bias_per_keyframe): only the frame that ends the keyframe's span learns,
  // below, once the keyframe decision is made.
  const bool bias_per_keyframe = params_.gyro_bias_per_keyframe && kf_usable;
  // The same vision-only motion is the inertial estimator's measurement: the prior-refined one
  // would feed the gyro back to the filter as if vision had seen it.
  std::optional<MotionRefinementResult> vision_alone;
  if (vision_ok && have_imu) {
    vision_alone = refineMotion(rig, quads, ransac.inliers, ransac.T_prev_curr, RotationPrior{}, params_.refinement,
                                work_.refinement);
    if (!vision_alone->ok) vision_alone.reset();
  }
  if (vision_alone && params_.gyro_bias_gain > 0 && !bias_per_keyframe)
    R_ref_curr_vision = vision_alone->T_prev_curr.rotation();
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

  // The inertial estimator takes the vision-only motion since the previous frame; a motion its
  // gate refuses is not used for the pose either (the frame coasts, flagged).
  if (filter_.started()) {
    if (vision_ok && vision_alone) {
      const imu::RelativeMotion z = visionMotionSincePrevious(*vision_alone, prev.T_W_R0.inverse() * T_W_ref, T_B_R0);
      if (filter_.update(z) == imu::UpdateOutcome::kRefused) vision_ok = false;
    }
    filter_.clonePose();
  }

  // The state at the start of the interval, for the gravity tilt observation below.
  const Eigen::Vector3d v_start_W = state_.v_W;
  const Eigen::Matrix3d R_start_W_B = state_.T_W_B.rotation();
  const Eigen::Vector3d p_start_W = state_.T_W_B.translation();
  const int64_t t_start_ns = state_.t_ns;
  if (vision_ok) {
    // Velocity: the visual displacement corrects the IMU's start velocity (III-A feeds III-C
    // and the visual pose feeds the next prediction).
    Eigen::Vector3d v = pred.state.v_W;
    if (dt_s > 1e-6) v += (T_W_B.translation() - map_shift_W - pred.state.T_W_B.translation()) / dt_s;
    if (have_imu && dt_ref_s > 1e-6 && R_ref_curr_vision) {
      // Gyro bias from the residual between the IMU rotation and the vision-only rotation,
      // lightly filtered; the prior-refined rotation would only echo the IMU.
      const Eigen::Vector3d residual = se3::logSO3(R_ref_curr_gyro.transpose() * *R_ref_curr_vision) / dt_ref_s;
      const Eigen::Vector3d residual_B = weightTilt(T_B_R0.rotation() * residual, state_.T_W_B.rotation(),
                                                    params_.gyro_bias_vision_tilt_weight);
      state_.gyro_bias_rad_s -= gyroBiasGain(params_, dt_s) * residual_B;
      gyro_bias_sigma_rad_s_ = std::max(params_.gyro_bias_sigma_at_rest_rad_s, gyro_bias_sigma_rad_s_ * 0.99);
    }
    // This interval for the velocity handed over if vision is lost next (a fit over
    // the last fixes, core/imu/coasting_handover.hpp); the state's own velocity is unchanged.
    if (have_imu)
      handover_.add({frame.t_ns, T_W_B.translation() - map_shift_W - state_.T_W_B.translation(),
                     pred.state.v_W - state_.v_W,
                     pred.state.T_W_B.translation() - state_.T_W_B.translation() - state_.v_W * dt_s});
    else
      handover_.reset();
    // A map correction is not motion: it turns the velocity with the frame, as a deferred
    // correction does (applyGlobalCorrection), whichever parts of the pose it moved
    // (map_keeps_tilt); with the tilt kept the accelerometer-bias window turned with it.
    if (map_delta_W) v = map_delta_W->linear() * v;
    state_.T_W_B = T_W_B;
    state_.v_W = v;
    state_covariance_ = imu::Matrix9d::Zero();
    state_covariance_.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * std::pow(params_.attitude_sigma_rad, 2);
    state_covariance_.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * std::pow(params_.velocity_sigma_m_s, 2);
    if (on_keyframe) pose_covariance_ = keyframe_->pose_covariance;
    // The reference's rotation error turns this step, and the heading random-walks with the
    // gyro-bias error since the reference (chain_covariance.hpp: the global search's sigma).
    const double bias_time_constant_s = params_.gyro_bias_gain > 0 ? dt_s / gyroBiasGain(params_, dt_s) : 0.0;
    composeChainCovariance(pose_covariance_, rel_cov, T_W_ref.rotation(),
                           T_W_R0.translation() - map_shift_W - T_W_ref.translation(),
                           headingVariance(params_.heading_bias_error_rad_s, bias_time_constant_s, dt_ref_s));
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
    if (have_imu) {
      // Vision minus prediction, map corrections excluded: both the windows and the leak read it.
      const Eigen::Vector3d innovation_W = T_W_B.translation() - map_shift_W - pred.state.T_W_B.translation();
      coasting_leak_.fix(innovation_W, dt_s, frame.t_ns);
    } else {
      coasting_leak_.reset();
    }
    coasting_.stop();
    coasting_leak_applied_ = false;
    r.source = PoseSource::kVision;
  } else {
    // Vision failed: coast on the IMU, flagged, with the covariance it deserves.
    const Eigen::Vector3d bg = state_.gyro_bias_rad_s, ba = state_.accel_bias_m_s2;
    const Eigen::Matrix3d prev_state_R = state_.T_W_B.rotation();
    const int64_t prev_state_t_ns = state_.t_ns;
    const Eigen::Vector3d prev_state_v = state_.v_W;
    state_ = pred.state;
    state_.gyro_bias_rad_s = bg;
    state_.accel_bias_m_s2 = ba;
    state_covariance_ = pred.covariance;
    if (have_imu) {
      // One correlated error state from the last visual fix (core/imu/coasting_covariance.hpp):
      // summing per-frame covariances would drop the velocity, tilt and bias correlations
      // that make dead-reckoning error grow with the square of time.
      if (!coasting_.active()) {
        coasting_correction_ = CoastingCorrection::kBare;
        coast_start_pose_covariance_ = pose_covariance_;
        coasting_.start({params_.attitude_sigma_rad, params_.velocity_sigma_m_s, gyro_bias_sigma_rad_s_,
                         params_.accel_bias_sigma_m_s2});
        // The velocity fitted over the last visual fixes replaces the last frame's
        // (a whole frame's position residual over 0.1 s), with the uncertainty of that fit.
        // Dead reckoning is linear in its start velocity, so this frame's prediction moves by
        // the difference times dt.
        const std::optional<imu::HandoverVelocity> hv =
            params_.coasting_velocity_window_s > 0
                ? handover_.velocity({params_.coasting_velocity_window_s, params_.coasting_velocity_min_fixes,
                                      params_.coasting_acceleration_min_fixes})
                : std::nullopt;
        if (hv) {
          coasting_correction_ = CoastingCorrection::kHandoverFit;
          const Eigen::Vector3d dv = hv->v_W - prev_state_v;
          state_.T_W_B.translation() += dv * dt_s;
          state_.v_W += dv;
          const Eigen::Vector3d f_B = interval.empty()
                                          ? Eigen::Vector3d(prev_state_R.transpose() * -imu::gravityW())
                                          : Eigen::Vector3d(interval.front().accel_m_s2 - ba);
          if (hv->has_acceleration)
            coasting_.setMeasuredMotion(hv->covariance, hv->velocity_acceleration_covariance,
                                        hv->acceleration_covariance, hv->acceleration_error, prev_state_R);
          else
            coasting_.setMeasuredVelocity(hv->covariance, hv->age_s, prev_state_R, f_B);
        } else if (const std::optional<imu::LeakEstimate> leak =
                       params_.coasting_leak_correction ? coasting_leak_.estimate(frame.t_ns, params_.coasting_leak)
                                                        : std::nullopt) {
          // 1 Hz: no handover fit; the leak the last steady fixes agree on
          // (core/imu/coasting_leak.hpp). The last fix left the velocity low by the leak x
          // dt / 2 (its error is the correction's error times that lag); the correction then
          // acts on every coasted interval below. Fixes that disagree correct nothing and
          // only widen the covariance by a leak of their size.
          const Eigen::Vector3d dv = leak->acceleration_W * leak->velocity_lag_s;
          state_.T_W_B.translation() += dv * dt_s;
          state_.v_W += dv;
          const Eigen::Matrix3d velocity_cov =
              Eigen::Matrix3d::Identity() * std::pow(params_.velocity_sigma_m_s, 2) +
              leak->velocity_lag_s * leak->velocity_lag_s * leak->covariance;
          coasting_.setMeasuredMotion(velocity_cov, leak->velocity_lag_s * leak->covariance, leak->covariance,
                                      leak->acceleration_W, prev_state_R);
          coasting_leak_applied_ = leak->consistent;
          coasting_correction_ =
              leak->consistent ? CoastingCorrection::kAgreedLeak : CoastingCorrection::kCovarianceOnly;
        }
      }
      // The acceleration the IMU missed before the loss, measured by the fit (mostly the
      // visual tilt's error times g), is added to the dead reckoning over this interval.
      const Eigen::Vector3d& da = coasting_.accelerationCorrection();
      state_.T_W_B.translation() += 0.5 * da * dt_s * dt_s;
      state_.v_W += da * dt_s;
      coasting_.propagate(prev_state_R, bg, ba, interval, prev_state_t_ns, frame.t_ns, imu_noise_);
      pose_covariance_ = coast_start_pose_covariance_ + coasting_.poseCovariance(state_.T_W_B.rotation());
    } else {
      accumulate(pose_covariance_, relativeCovariance(pred.covariance), Eigen::Matrix3d::Identity());
    }
    T_W_B = state_.T_W_B;
    T_W_R0 = T_W_B * T_B_R0;
    r.source = PoseSource::kImuOnly;
    r.coasting = have_imu ? coasting_correction_ : CoastingCorrection::kNoImu;
    r.refusal = refusal;
    handover_.reset();
    coasting_leak_.coast();
  }
  // While the vehicle still holds still after start-up, every interval refines the gyro bias.
  if (still_start_ && have_imu) {
    const Eigen::Isometry3d motion = prev.T_W_R0.inverse() * T_W_R0;
    const bool vision_still = r.source == PoseSource::kVision && motion.translation().norm() < 2e-3 &&
                              se3::angle(motion) < 1e-3;
    if (vision_still && imu::gyroBiasAtRest(interval, 0.5 * dt_s)) {
      for (const ImuSample& s : interval) still_gyro_sum_ += s.gyro_rad_s;
      still_samples_ += static_cast<int>(interval.size());
      state_.gyro_bias_rad_s = still_gyro_sum_ / still_samples_;
      const double still_s = still_samples_ / std::max(imu_noise_.rate_hz, 1.0);
      gyro_bias_sigma_rad_s_ = std::max(params_.gyro_bias_sigma_at_rest_rad_s,
                                        imu_noise_.gyroscope_noise_density / std::sqrt(std::max(still_s, 1e-3)));
    } else {
      still_start_ = false;
    }
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
    handover_.reset();
    coasting_leak_.reset();
  }
  last_motion_ = prev.T_W_R0.inverse() * T_W_R0;
  last_dt_s_ = dt_s;
  if (params_.gyro_bias_gravity_window_s > 0 &&
      !(params_.accel_bias_estimation && params_.accel_bias.gyro_bias_states)) {
    // Tilt rates of the gyro bias from gravity (core/imu/gravity_bias_observer.hpp): only over
    // contiguous visual frames, and once the still start ended. A map correction of this frame
    // moves the chain: the observer's windows and this interval's start follow it into the
    // corrected frame (the interval ends at the corrected pose).
    if (r.source == PoseSource::kVision && have_imu && !interval.empty() && !still_start_) {
      Eigen::Vector3d p0_W = p_start_W;
      Eigen::Matrix3d R0_W_B = R_start_W_B;
      if (map_delta_W) {
        gravity_bias_.moveChain(*map_delta_W);
        p0_W = *map_delta_W * p0_W;
        R0_W_B = map_delta_W->linear() * R0_W_B;
      }
      const Eigen::Vector3d f_B = meanSpecificForce(interval, state_.accel_bias_m_s2);
      const Eigen::Matrix3d R_mid = midAttitude(R0_W_B, state_.T_W_B.rotation());
      if (const auto eps = gravity_bias_.add(t_start_ns, p0_W, state_.t_ns, state_.T_W_B.translation(), R_mid, f_B,
                                             state_.T_W_B.rotation()))
        state_.gyro_bias_rad_s += params_.gyro_bias_gravity_gain * *eps;
    } else {
      gravity_bias_.reset();
    }
  }

  // The two absolute tilt references below come after the tilt-rate observer has taken this
  // interval: the chain turns they apply move the observer's windows with it (turnChain), so
  // it does not read their step as a gyro-bias rate and steer the chain back.
  if (params_.accel_bias_estimation && have_imu) {
    // Accelerometer bias and tilt (accel_bias_estimation, core/imu/accel_bias_estimator.hpp):
    // this interval into the window; a fix that ends a long enough window updates the filter,
    // which turns the chain's roll/pitch (about the current position, keyframe and previous
    // frame with it, as a map correction does) and sets the bias the next prediction uses.
    // Coasting, or a map correction that moved the frame, interrupts the velocity chain;
    // unless the map only turns the heading (map_keeps_tilt): the window turns with it.
    const bool map_moved = map_delta_W || inline_revisit;
    const bool fix = r.source == PoseSource::kVision && (!map_moved || params_.map_keeps_tilt);
    if (!fix) accel_bias_.breakWindow();
    if (fix && map_delta_W) accel_bias_.turnWindow(map_delta_W->linear());
    accel_bias_.addInterval(R_start_W_B, state_.gyro_bias_rad_s, interval, t_start_ns, frame.t_ns);
    if (fix) {
      if (accel_bias_.close(state_.v_W) == imu::AccelBiasEstimator::Outcome::kUpdated) {
        turnChain(se3::expSO3(accel_bias_.tiltCorrection()), T_W_R0);
        state_.gyro_bias_rad_s += accel_bias_.gyroBiasCorrection();
      }
      if (!accel_bias_.windowOpen()) accel_bias_.startWindow(state_.v_W);
    }
    state_.accel_bias_m_s2 = accel_bias_.bias();
  }
  if (params_.gravity_tilt_time_constant_s > 0 && !params_.accel_bias_estimation && r.source == PoseSource::kVision &&
      have_imu && dt_s > 1e-3 && !interval.empty()) {
    // Gravity as the tilt reference (see gravity_tilt_time_constant_s): the mean specific
    // force over the interval, turned into W at the interval's middle attitude, against the
    // world acceleration vision measured (velocity change) minus gravity. Heading is not
    // observed by gravity, so only the horizontal axes of the misalignment are corrected.
    const Eigen::Vector3d f_B = meanSpecificForce(interval, state_.accel_bias_m_s2);
    const Eigen::Matrix3d R_mid = midAttitude(R_start_W_B, state_.T_W_B.rotation());
    const Eigen::Vector3d a_W = (state_.v_W - v_start_W) / dt_s;
    const Eigen::Vector3d measured = R_mid * f_B, expected = a_W - imu::gravityW();
    if (measured.norm() > 1.0 && expected.norm() > 1.0) {
      Eigen::Vector3d misalignment = measured.normalized().cross(expected.normalized());
      misalignment.z() = 0;
      const double gain = 1.0 - std::exp(-dt_s / params_.gravity_tilt_time_constant_s);
      turnChain(se3::expSO3(gain * misalignment), T_W_R0);
    }
  }

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
    if (on_keyframe && r.source == PoseSource::kVision) ++keyframe_->frames_tracked;
    if (keep) {
      keyframe_->R_kf_prev_gyro = R_ref_curr_gyro;
      keyframe_->gyro_covariance = ref_gyro_cov + pred_cov.topLeftCorner<3, 3>();
    } else {
      if (bias_per_keyframe && on_keyframe && r.source == PoseSource::kVision && have_imu && !still_start_ &&
          params_.gyro_bias_gain > 0 && dt_ref_s > 1e-6) {
        // The span's last frame: gyro against the prior-free four-view rotation over the whole
        // keyframe interval (its visual noise divided by the longest dt). The gain of the
        // frames served keeps the filter's bandwidth per second that of the per-frame update.
        const MotionRefinementResult alone =
            refineMotion(rig, quads, ransac.inliers, ransac.T_prev_curr, RotationPrior{}, params_.refinement,
                         work_.refinement);
        if (alone.ok) {
          const int n = std::max(keyframe_->frames_tracked, 1);
          const double gain = std::min(1.0, gyroBiasGain(params_, dt_s) * n);
          const Eigen::Vector3d residual =
              se3::logSO3(R_ref_curr_gyro.transpose() * alone.T_prev_curr.rotation()) / dt_ref_s;
          state_.gyro_bias_rad_s -= gain * weightTilt(T_B_R0.rotation() * residual, state_.T_W_B.rotation(),
                                                      params_.gyro_bias_vision_tilt_weight);
          gyro_bias_sigma_rad_s_ =
              std::max(params_.gyro_bias_sigma_at_rest_rad_s, gyro_bias_sigma_rad_s_ * std::pow(0.99, n));
        }
        r.times.tensor_ms += timer.lap_ms();
      }
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
  if (!params_.accel_bias_estimation || !params_.accel_bias_start_frame) return;
  // The chain's increments turned into the start-up frame (accel_bias_start_frame): a change of
  // the start-up tilt's estimate turns what follows, never what was already published.
  const Eigen::Matrix3d R_0 = se3::expSO3(accel_bias_.initialTilt());
  published_p_W_ += R_0 * (state_.T_W_B.translation() - published_from_p_W_);
  published_from_p_W_ = state_.T_W_B.translation();
  r.T_W_B.linear() = R_0 * state_.T_W_B.linear();
  r.T_W_B.translation() = published_p_W_;
  r.v_W = R_0 * state_.v_W;
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = J.bottomRightCorner<3, 3>() = R_0;
  r.covariance = J * pose_covariance_ * J.transpose();
}

void Odometry::turnChain(const Eigen::Matrix3d& R, Eigen::Isometry3d& T_W_R0) {
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  D.linear() = R;
  D.translation() = state_.T_W_B.translation() - D.linear() * state_.T_W_B.translation();
  state_.T_W_B = orthonormalized(D * state_.T_W_B);
  state_.v_W = D.linear() * state_.v_W;
  T_W_R0 = orthonormalized(D * T_W_R0);
  if (keyframe_) keyframe_->T_W_R0 = orthonormalized(D * keyframe_->T_W_R0);
  gravity_bias_.moveChain(D);
}

Eigen::Matrix3d Odometry::gyroBiasRotationCovariance(const Eigen::Matrix3d& R_B_R0, double dt_s) const {
  if (!params_.gyro_bias_prior_tilt_from_filter || !params_.accel_bias_estimation ||
      !params_.accel_bias.gyro_bias_states)
    return Eigen::Matrix3d::Identity() * std::pow(gyro_bias_sigma_rad_s_ * dt_s, 2);  // the same in every frame
  // The tilt rates are the accelerometer-bias filter's states (vision learns the heading only,
  // gyro_bias_vision_tilt_weight 0). Gravity pins them within a leg (5e-5 rad/s), well below the
  // floor the heading keeps; the floor on them let a 1 Hz step's prior-free pitch, which trades
  // with surge over a flat floor (paper III-C) and has a mean of ~3e-4 rad per step, into
  // the attitude (git history of docs/benchmarks.md).
  Eigen::Matrix3d cov_B = Eigen::Matrix3d::Identity() * gyro_bias_sigma_rad_s_ * gyro_bias_sigma_rad_s_;
  cov_B.topLeftCorner<2, 2>() = accel_bias_.gyroBiasCovariance();
  return R_B_R0.transpose() * cov_B * R_B_R0 * (dt_s * dt_s);
}

}  // namespace seavio::odometry
