#include "core/odometry/odometry.hpp"

#include <algorithm>
#include <cmath>

#include "core/common/se3.hpp"
#include "core/common/stage_timer.hpp"
#include "core/odometry/motion_refinement.hpp"

namespace seavio::odometry {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

bool finitePose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

/// `T` with its linear part projected back onto SO(3). Isometry3d::inverse() and rotation()
/// take the linear part as orthonormal; a pose composed frame after frame and fed back through
/// the IMU prediction (pose^-1 * predicted pose) otherwise doubles its round-off every frame,
/// until the world rotation carries a ~0.5 % scale that shortens every published step.
Eigen::Isometry3d orthonormalized(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = T;
  out.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  return out;
}

/// Relative-motion covariance (rotation, translation) from the propagated error state.
Matrix6d relativeCovariance(const imu::Matrix9d& P) {
  Matrix6d C = Matrix6d::Zero();
  C.topLeftCorner<3, 3>() = P.topLeftCorner<3, 3>();
  C.bottomRightCorner<3, 3>() = P.block<3, 3>(6, 6);
  return C;
}

/// Adds a relative-motion covariance expressed in frame `R_W_a` to an absolute one in W.
void accumulate(Matrix6d& absolute, const Matrix6d& relative, const Eigen::Matrix3d& R_W_a) {
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = R_W_a;
  J.bottomRightCorner<3, 3>() = R_W_a;
  absolute += J * relative * J.transpose();
}

}  // namespace

Odometry::Odometry(camera::StereoRectifier rectifier, const imu::ImuNoise& imu_noise, const OdometryParams& params,
                   NowNsFn now)
    : frontend_(std::move(rectifier), params.features, params.stereo, params.illumination, params.snow),
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
      map_(params.map),
      rng_(params.seed) {}

OdometryResult Odometry::process(const StereoFrame& frame, std::span<const ImuSample> imu) {
  FrameFeatures f = frontend_.process(frame, controller_.threshold(), now_);
  return track(std::move(f), imu);
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
  initialised_ = true;
}

OdometryResult Odometry::track(FrameFeatures&& frame, std::span<const ImuSample> imu) {
  StageTimer timer(now_);
  OdometryResult r;
  r.t_ns = frame.t_ns;
  r.seq = frame.seq;
  r.times = frame.times;
  r.quality.features_left = static_cast<int>(frame.left.keypoints.size());
  r.quality.features_right = static_cast<int>(frame.right.keypoints.size());
  r.quality.stereo_matches = static_cast<int>(frame.stereo.points.size());
  r.quality.detector_threshold = frame.detector_threshold;
  // Paper III-B: a proportional controller holds the feature count.
  controller_.update(static_cast<int>(frame.left.keypoints.size()));

  // Keep IMU samples across calls so integration can interpolate at the frame boundaries.
  for (const ImuSample& s : imu)
    if (imu_buffer_.empty() || s.t_ns > imu_buffer_.back().t_ns) imu_buffer_.push_back(s);

  const camera::RectifiedRig& rig = frontend_.rig();
  const Eigen::Isometry3d T_B_R0 = rig.T_B_R0;

  if (!initialised_) {
    initialise(frame, imu_buffer_);
    r.T_W_B = state_.T_W_B;
    r.source = PoseSource::kInit;
    r.covariance = pose_covariance_;
    const Eigen::Isometry3d T_W_R0 = state_.T_W_B * T_B_R0;
    if (params_.mode == Mode::kGlobal) {
      map_.insert(map::MapFrame{frame.seq, frame.t_ns, T_W_R0, [&] {
                                  std::vector<Eigen::Vector3f> p;
                                  for (const auto& sp : frame.stereo.points) p.push_back(sp.p_R0);
                                  return p;
                                }()});
      storeRevisitFrame(frame.seq, frame.stereo, T_W_R0, frame.t_ns);
    }
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
  if (have_imu) {
    pred = imu::propagate(state_, start_cov, imu_buffer_, frame.t_ns, imu_noise_);
    pred.state.T_W_B = orthonormalized(pred.state.T_W_B);
    T_prev_curr_pred = orthonormalized((state_.T_W_B * T_B_R0).inverse() * (pred.state.T_W_B * T_B_R0));
    pred_cov = relativeCovariance(pred.covariance);
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
  std::vector<ImuSample> interval;
  for (const ImuSample& s : imu_buffer_)
    if (s.t_ns > state_.t_ns && s.t_ns <= frame.t_ns) interval.push_back(s);
  while (imu_buffer_.size() > 2 && imu_buffer_[1].t_ns <= frame.t_ns) imu_buffer_.erase(imu_buffer_.begin());

  // --- III-C: inter-frame matching pruned by the prediction.
  const PreviousFrame& prev = *previous_;
  auto temporal = matching::matchTemporal(prev.features.stereo, frame.stereo, rig, T_prev_curr_pred, pred_cov,
                                                params_.temporal);
  r.quality.temporal_matches = static_cast<int>(temporal.size());
  r.times.temporal_ms = timer.lap_ms();

  // --- III-C: quadrifocal tensor of the two pairs, RANSAC + refinement.
  std::vector<geometry::QuadMatch> quads;
  const auto toQuads = [&] {
    quads.clear();
    quads.reserve(temporal.size());
    for (const auto& m : temporal) {
      const auto& a = prev.features.stereo.points[static_cast<std::size_t>(m.prev)];
      const auto& b = frame.stereo.points[static_cast<std::size_t>(m.curr)];
      quads.push_back(geometry::QuadMatch{a.uv_left, a.uv_right, b.uv_left, b.uv_right});
    }
  };
  toQuads();
  geometry::RansacResult ransac = ransac_.estimate(quads, T_prev_curr_pred, rng_);
  bool vision_ok = ransac.status == geometry::RansacStatus::kOk &&
                   static_cast<int>(ransac.inliers.size()) >= params_.min_inliers && finitePose(ransac.T_prev_curr);
  const auto rescue = [&] {
    if (static_cast<int>(quads.size()) < params_.rescue_min_inliers) return false;
    geometry::RansacResult second = rescue_ransac_.estimate(quads, T_prev_curr_pred, rng_);
    if (second.status != geometry::RansacStatus::kOk ||
        static_cast<int>(second.inliers.size()) < params_.rescue_min_inliers || !finitePose(second.T_prev_curr))
      return false;
    ransac = std::move(second);
    return true;
  };
  if (!vision_ok && params_.rescue_inlier_threshold_px > 0) {
    vision_ok = rescue();
    if (!vision_ok && params_.temporal.use_prediction) {
      // After a lost frame the coasting prediction can be too wrong for its windows (a fast
      // turn, a velocity gone stale): search the whole image once, so tracking comes back.
      matching::TemporalMatchParams whole = params_.temporal;
      whole.use_prediction = false;
      temporal = matching::matchTemporal(prev.features.stereo, frame.stereo, rig, T_prev_curr_pred, pred_cov, whole);
      toQuads();
      vision_ok = rescue();
    }
  }
  r.quality.ransac_inliers = static_cast<int>(ransac.inliers.size());
  r.times.tensor_ms = timer.lap_ms();

  Eigen::Isometry3d T_prev_curr = vision_ok ? ransac.T_prev_curr : T_prev_curr_pred;
  Matrix6d rel_cov = vision_ok ? Matrix6d(ransac.covariance) : pred_cov;
  if (vision_ok && params_.use_rotation_prior) {
    // IMU-aided refinement: the gyro's rotation as a prior removes the pitch/surge ambiguity
    // of a flat floor (see motion_refinement.hpp).
    RotationPrior prior;
    prior.valid = have_imu;
    prior.R_prev_curr = T_prev_curr_pred.rotation();
    // Relative rotation noise only: the absolute attitude uncertainty carried in the start
    // covariance passes through the short propagation unchanged (F ~ I) and is removed.
    prior.covariance = pred_cov.topLeftCorner<3, 3>() - start_cov.topLeftCorner<3, 3>() +
                       Eigen::Matrix3d::Identity() * std::pow(gyro_bias_sigma_rad_s_ * dt_s, 2);
    const MotionRefinementResult refined =
        refineMotion(rig, quads, ransac.inliers, T_prev_curr, prior, params_.refinement);
    if (refined.ok) {
      T_prev_curr = refined.T_prev_curr;
      rel_cov = refined.covariance;
    }
  }
  Eigen::Isometry3d T_W_R0 = prev.T_W_R0 * T_prev_curr;

  // --- III-D/E: ICP against the previous frame (local) or the map near the prediction (global).
  std::vector<Eigen::Vector3f> data;
  data.reserve(frame.stereo.points.size());
  for (const auto& sp : frame.stereo.points) data.push_back(sp.p_R0);
  // Global mode: how far the map moved the frame off its odometry. A correction is not
  // motion, so it stays out of the speed check and the velocity.
  Eigen::Vector3d map_shift_W = Eigen::Vector3d::Zero();
  if (vision_ok) {
    std::vector<std::pair<int, int>> seeds;
    seeds.reserve(ransac.inliers.size());
    if (params_.mode == Mode::kLocal) {
      std::vector<Eigen::Vector3f> model;
      model.reserve(prev.features.stereo.points.size());
      for (const auto& sp : prev.features.stereo.points) model.push_back(sp.p_R0);
      for (uint32_t i : ransac.inliers) seeds.emplace_back(temporal[i].curr, temporal[i].prev);
      const icp::PointCloudIndex index(model);
      const icp::IcpResult icp = icp::alignIcp(data, model, index, seeds, T_prev_curr, params_.icp);
      r.quality.icp_iterations = icp.iterations;
      r.quality.icp_inliers = icp.inliers;
      r.quality.icp_rms_m = icp.rms_m;
      r.quality.model_points = static_cast<int>(model.size());
      if (icp.status == icp::IcpStatus::kOk && params_.final_stage == FinalStage::kIcp && finitePose(icp.T_model_data)) {
        T_prev_curr = icp.T_model_data;
        T_W_R0 = prev.T_W_R0 * T_prev_curr;
      }
    } else {
      const auto selected = map_.selectNear(T_W_R0.translation());
      const Eigen::Isometry3d T_W_R0_odometry = T_W_R0;
      if (correctFromRevisit(frame.stereo, selected, frame.t_ns, T_W_R0)) {
        T_prev_curr = prev.T_W_R0.inverse() * T_W_R0;
        map_shift_W = T_W_R0.translation() - T_W_R0_odometry.translation();
      }
      // Registering against frames just behind us only re-measures the motion the tensor
      // already measured better; the map bounds the drift when the survey comes back over
      // older ground (paper III-D), so ICP runs when the selection holds such frames.
      const int64_t revisit_ns = static_cast<int64_t>(params_.min_revisit_age_s * 1e9);
      const bool revisit = std::any_of(selected.begin(), selected.end(), [&](const map::MapFrame* f) {
        return frame.t_ns - f->t_ns >= revisit_ns;
      });
      const map::ModelCloud model = revisit ? map_.buildModel(selected) : map::ModelCloud{};
      r.quality.model_points = static_cast<int>(model.points_W.size());
      if (!model.points_W.empty()) {
        const icp::PointCloudIndex index(model.points_W);
        // Descriptor seeds are only known against the previous frame; the rest is geometry.
        const icp::IcpResult icp = icp::alignIcp(data, model.points_W, index, {}, T_W_R0, params_.icp);
        r.quality.icp_iterations = icp.iterations;
        r.quality.icp_inliers = icp.inliers;
        r.quality.icp_rms_m = icp.rms_m;
        // Gate: the map may pull the frame only as far as the odometry could plausibly have
        // drifted; a larger correction is an ICP local minimum, not information.
        const Eigen::Isometry3d correction = T_W_R0.inverse() * icp.T_model_data;
        if (icp.status == icp::IcpStatus::kOk && finitePose(icp.T_model_data) &&
            correction.translation().norm() <= params_.max_map_correction_m &&
            se3::angle(correction) <= params_.max_map_correction_rad) {
          map_shift_W += icp.T_model_data.translation() - T_W_R0.translation();
          T_W_R0 = icp.T_model_data;
          T_prev_curr = prev.T_W_R0.inverse() * T_W_R0;
        }
      }
    }
  }
  r.times.icp_ms = timer.lap_ms();

  T_W_R0 = orthonormalized(T_W_R0);
  Eigen::Isometry3d T_W_B = orthonormalized(T_W_R0 * T_B_R0.inverse());
  if (vision_ok && dt_s > 0 &&
      (T_W_B.translation() - map_shift_W - state_.T_W_B.translation()).norm() / dt_s > params_.max_speed_m_s) {
    vision_ok = false;  // a jump: refuse it rather than publish it
  }

  if (vision_ok) {
    // Velocity: the visual displacement corrects the IMU's start velocity (III-A feeds III-C
    // and the visual pose feeds the next prediction).
    Eigen::Vector3d v = pred.state.v_W;
    if (dt_s > 1e-6) v += (T_W_B.translation() - map_shift_W - pred.state.T_W_B.translation()) / dt_s;
    if (have_imu && dt_s > 1e-6 && ransac.status == geometry::RansacStatus::kOk) {
      // Gyro bias from the residual between the IMU rotation and the vision-only (RANSAC)
      // rotation, lightly filtered; the prior-refined rotation would only echo the IMU.
      const Eigen::Vector3d residual =
          se3::logSO3(T_prev_curr_pred.rotation().transpose() * ransac.T_prev_curr.rotation()) / dt_s;
      const Eigen::Vector3d residual_B = T_B_R0.rotation() * residual;
      state_.gyro_bias_rad_s -= params_.gyro_bias_gain * residual_B;
      gyro_bias_sigma_rad_s_ = std::max(params_.gyro_bias_sigma_at_rest_rad_s, gyro_bias_sigma_rad_s_ * 0.99);
    }
    state_.T_W_B = T_W_B;
    state_.v_W = v;
    state_covariance_ = imu::Matrix9d::Zero();
    state_covariance_.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * std::pow(params_.attitude_sigma_rad, 2);
    state_covariance_.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * std::pow(params_.velocity_sigma_m_s, 2);
    accumulate(pose_covariance_, rel_cov, prev.T_W_R0.rotation());
    r.source = PoseSource::kVision;
  } else {
    // Vision failed: coast on the IMU, flagged, with the covariance it deserves.
    const Eigen::Vector3d bg = state_.gyro_bias_rad_s, ba = state_.accel_bias_m_s2;
    state_ = pred.state;
    state_.gyro_bias_rad_s = bg;
    state_.accel_bias_m_s2 = ba;
    state_covariance_ = pred.covariance;
    accumulate(pose_covariance_, relativeCovariance(pred.covariance), Eigen::Matrix3d::Identity());
    T_W_B = state_.T_W_B;
    T_W_R0 = T_W_B * T_B_R0;
    r.source = PoseSource::kImuOnly;
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
  }
  last_motion_ = prev.T_W_R0.inverse() * T_W_R0;
  last_dt_s_ = dt_s;

  if (params_.mode == Mode::kGlobal && r.source == PoseSource::kVision && map_.wantsKeyframe(T_W_R0)) {
    map_.insert(map::MapFrame{frame.seq, frame.t_ns, T_W_R0, data});
    if ((T_W_R0.translation() - last_revisit_position_).norm() >= params_.revisit_keyframe_distance_m)
      storeRevisitFrame(frame.seq, frame.stereo, T_W_R0, frame.t_ns);
  }

  r.T_W_B = state_.T_W_B;
  r.v_W = state_.v_W;
  r.covariance = pose_covariance_;
  previous_ = PreviousFrame{std::move(frame), T_W_R0, r.t_ns};
  r.times.total_ms = r.times.rectify_ms + r.times.features_ms + r.times.stereo_ms + timer.total_ms();
  return r;
}

void Odometry::storeRevisitFrame(uint64_t id, const matching::StereoFeatures& features,
                                 const Eigen::Isometry3d& T_W_R0, int64_t t_ns) {
  RevisitFrame f;
  f.t_ns = t_ns;
  f.T_W_R0 = T_W_R0;
  f.position_variance_m2 = pose_covariance_.bottomRightCorner<3, 3>().trace();
  // Compact: an even subsample of the points, float descriptors (unit length, so every
  // component in [-1, 1]) quantised to 8 bits.
  const std::size_t n = features.points.size();
  const std::size_t keep = std::min(n, static_cast<std::size_t>(std::max(params_.revisit_max_points, 1)));
  if (keep == 0 || features.descriptors.rows != static_cast<int>(n)) return;
  const double step = static_cast<double>(n) / static_cast<double>(keep);
  cv::Mat rows(static_cast<int>(keep), features.descriptors.cols, features.descriptors.type());
  for (std::size_t i = 0; i < keep; ++i) {
    const auto src = static_cast<std::size_t>(static_cast<double>(i) * step);
    f.features.points.push_back(features.points[src]);
    f.features.laplacian_sign.push_back(features.laplacian_sign.empty() ? -1 : features.laplacian_sign[src]);
    features.descriptors.row(static_cast<int>(src)).copyTo(rows.row(static_cast<int>(i)));
  }
  if (rows.type() == CV_32F) {
    rows.convertTo(f.features.descriptors, CV_8S, 127.0);
  } else {
    f.features.descriptors = rows;
  }
  revisit_frames_[id] = std::move(f);
  last_revisit_position_ = T_W_R0.translation();
}

bool Odometry::correctFromRevisit(const matching::StereoFeatures& current,
                                  const std::vector<const map::MapFrame*>& selected, int64_t t_ns,
                                  Eigen::Isometry3d& T_W_R0) {
  const int64_t revisit_ns = static_cast<int64_t>(params_.min_revisit_age_s * 1e9);
  const RevisitFrame* old = nullptr;
  for (const map::MapFrame* f : selected) {  // nearest first
    if (t_ns - f->t_ns < revisit_ns) continue;
    const auto it = revisit_frames_.find(f->id);
    if (it != revisit_frames_.end()) {
      old = &it->second;
      break;
    }
  }
  if (old == nullptr) return false;
  matching::StereoFeatures old_features;
  old_features.points = old->features.points;
  old_features.laplacian_sign = old->features.laplacian_sign;
  if (old->features.descriptors.type() == CV_8S && current.descriptors.type() == CV_32F) {
    old->features.descriptors.convertTo(old_features.descriptors, CV_32F, 1.0 / 127.0);
  } else if (old->features.descriptors.type() == current.descriptors.type()) {
    old_features.descriptors = old->features.descriptors;
  } else {
    return false;
  }
  // The drift accumulated since the old frame sizes the search: the shared part of the two
  // poses' uncertainty cancels in their relative pose.
  const double drift_var = std::max(pose_covariance_.bottomRightCorner<3, 3>().trace() - old->position_variance_m2, 1e-4);
  Matrix6d cov = Matrix6d::Zero();
  cov.topLeftCorner<3, 3>() = pose_covariance_.topLeftCorner<3, 3>() + Eigen::Matrix3d::Identity() * 1e-6;
  cov.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * (drift_var / 3.0);
  const Eigen::Isometry3d guess = old->T_W_R0.inverse() * T_W_R0;
  const camera::RectifiedRig& rig = frontend_.rig();
  const auto matches = matching::matchTemporal(old_features, current, rig, guess, cov, params_.temporal);
  if (static_cast<int>(matches.size()) < params_.revisit_min_inliers) return false;
  std::vector<geometry::QuadMatch> quads;
  quads.reserve(matches.size());
  for (const auto& m : matches) {
    const auto& a = old_features.points[static_cast<std::size_t>(m.prev)];
    const auto& b = current.points[static_cast<std::size_t>(m.curr)];
    quads.push_back(geometry::QuadMatch{a.uv_left, a.uv_right, b.uv_left, b.uv_right});
  }
  const geometry::RansacResult ransac = ransac_.estimate(quads, guess, rng_);
  if (ransac.status != geometry::RansacStatus::kOk || static_cast<int>(ransac.inliers.size()) < params_.revisit_min_inliers ||
      !finitePose(ransac.T_prev_curr))
    return false;
  const Eigen::Isometry3d measured = old->T_W_R0 * ransac.T_prev_curr;
  const Eigen::Isometry3d correction = T_W_R0.inverse() * measured;
  if (correction.translation().norm() > params_.max_revisit_correction_m) return false;
  // Blend by uncertainty: the re-observation carries the old pose's error plus its own
  // noise, the odometry the same old error plus the drift since.
  const double meas_var = std::max(Matrix6d(ransac.covariance).bottomRightCorner<3, 3>().trace(), 1e-8);
  const double w = drift_var / (drift_var + meas_var);
  T_W_R0 = orthonormalized(T_W_R0 * se3::expSE3(w * se3::logSE3(correction)));
  pose_covariance_ *= (1.0 - w);
  pose_covariance_.bottomRightCorner<3, 3>() += Eigen::Matrix3d::Identity() * (w * old->position_variance_m2 / 3.0);
  ++revisit_corrections_;
  return true;
}

std::size_t Odometry::mapMemoryBytes() const {
  std::size_t bytes = map_.memoryBytes();
  for (const auto& [id, f] : revisit_frames_) {
    bytes += sizeof(id) + sizeof(f) + 16;
    bytes += f.features.points.capacity() * sizeof(matching::StereoPoint);
    bytes += f.features.laplacian_sign.capacity() * sizeof(int);
    bytes += f.features.descriptors.total() * f.features.descriptors.elemSize();
  }
  return bytes;
}

}  // namespace seavio::odometry
