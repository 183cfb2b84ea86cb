#include "tools/pnp_baseline.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "core/common/stage_timer.hpp"

namespace seavio::tools {

std::optional<PnpMotion> solvePnpMotion(const std::vector<cv::Point3f>& object_prev,
                                        const std::vector<cv::Point2f>& image_curr, const camera::RectifiedRig& rig,
                                        const PnpBaselineParams& params) {
  if (object_prev.size() != image_curr.size() || object_prev.size() < 6) return std::nullopt;
  const cv::Matx33d K(rig.f_px, 0, rig.cx, 0, rig.f_px, rig.cy, 0, 0, 1);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  if (!cv::solvePnPRansac(object_prev, image_curr, K, cv::noArray(), rvec, tvec, false, params.iterations,
                          static_cast<float>(params.reprojection_px), 0.999, inliers, cv::SOLVEPNP_ITERATIVE))
    return std::nullopt;
  // RANSAC's inliers are judged by a model fit to a few points; refining on all of them and
  // re-selecting with the refined motion is what makes the estimate use the whole frame.
  std::vector<cv::Point3f> obj;
  std::vector<cv::Point2f> img, projected;
  for (int round = 0; round < params.refine_rounds; ++round) {
    if (static_cast<int>(inliers.size()) < params.min_inliers) return std::nullopt;
    obj.clear();
    img.clear();
    for (const int i : inliers) {
      obj.push_back(object_prev[static_cast<std::size_t>(i)]);
      img.push_back(image_curr[static_cast<std::size_t>(i)]);
    }
    cv::solvePnPRefineLM(obj, img, K, cv::noArray(), rvec, tvec);
    cv::projectPoints(object_prev, rvec, tvec, K, cv::noArray(), projected);
    inliers.clear();
    const double max_sq = params.reprojection_px * params.reprojection_px;
    for (std::size_t i = 0; i < projected.size(); ++i) {
      const cv::Point2f d = projected[i] - image_curr[i];
      if (static_cast<double>(d.dot(d)) <= max_sq) inliers.push_back(static_cast<int>(i));
    }
  }
  if (static_cast<int>(inliers.size()) < params.min_inliers) return std::nullopt;
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  Eigen::Vector3d te;
  cv::cv2eigen(R, Re);
  cv::cv2eigen(tvec, te);
  if (!Re.allFinite() || !te.allFinite()) return std::nullopt;
  PnpMotion m;
  m.T_curr_prev.linear() = Re;
  m.T_curr_prev.translation() = te;
  m.inliers = static_cast<int>(inliers.size());
  return m;
}

bool PnpBaseline::plausible(const Eigen::Isometry3d& T_prev_curr, double dt_s) const {
  const double step_m = T_prev_curr.translation().norm();
  const double step_rad = Eigen::AngleAxisd(T_prev_curr.linear()).angle();
  const double last_m = step_.translation().norm();
  const double last_rad = Eigen::AngleAxisd(step_.linear()).angle();
  return step_m <= std::max(params_.max_step_ratio * last_m, params_.min_gate_speed_m_s * dt_s) &&
         step_rad <= std::max(params_.max_step_ratio * last_rad, params_.min_gate_rate_rad_s * dt_s);
}

OdometryResult PnpBaseline::process(const StereoFrame& frame, const NowNsFn& now) {
  return track(frontend_.process(frame, params_.threshold, now), now);
}

OdometryResult PnpBaseline::track(odometry::FrameFeatures f, const NowNsFn& now) {
  StageTimer timer(now);
  OdometryResult r;
  r.t_ns = f.t_ns;
  r.seq = f.seq;
  r.times = f.times;
  // The front end's stages were timed before this call; the frame's total counts them too.
  r.times.total_ms = f.times.rectify_ms + f.times.features_ms + f.times.stereo_ms;
  r.quality.features_left = static_cast<int>(f.left.keypoints.size());
  r.quality.features_right = static_cast<int>(f.right.keypoints.size());
  r.quality.stereo_matches = static_cast<int>(f.stereo.points.size());
  const auto& rig = frontend_.rig();
  const Eigen::Isometry3d T_R0_B = rig.T_B_R0.inverse();
  if (!reference_) {
    r.source = PoseSource::kInit;
    reference_ = std::move(f);
    last_t_ns_ = r.t_ns;
    r.T_W_B = T_W_R0_ * T_R0_B;
    r.times.total_ms += timer.total_ms();
    return r;
  }
  matching::TemporalMatchParams exhaustive;
  exhaustive.use_prediction = false;
  exhaustive.ratio = params_.ratio;
  const auto matches = matching::matchTemporal(reference_->stereo, f.stereo, rig, Eigen::Isometry3d::Identity(),
                                               Eigen::Matrix<double, 6, 6>::Identity(), exhaustive);
  r.quality.temporal_matches = static_cast<int>(matches.size());
  r.times.temporal_ms = timer.lap_ms();
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  for (const auto& m : matches) {
    const auto& p = reference_->stereo.points[static_cast<std::size_t>(m.prev)].p_R0;
    const auto& uv = f.stereo.points[static_cast<std::size_t>(m.curr)].uv_left;
    object.emplace_back(p.x(), p.y(), p.z());
    image.emplace_back(uv.x(), uv.y());
  }
  const auto motion = solvePnpMotion(object, image, rig, params_);
  r.times.tensor_ms = timer.lap_ms();  // the PnP-RANSAC fills the tensor column of Table II
  const double dt_s = static_cast<double>(r.t_ns - last_t_ns_) * 1e-9;
  bool ok = false;
  if (motion) {
    r.quality.ransac_inliers = motion->inliers;
    const Eigen::Isometry3d T_W_curr = T_W_ref_ * motion->T_curr_prev.inverse();
    const Eigen::Isometry3d T_prev_curr = T_W_R0_.inverse() * T_W_curr;
    // A wrong PnP solution (a repeated pattern, matches on a few clustered points) gives a
    // jump no vehicle makes between two frames; chaining it would ruin the rest of the run.
    ok = !step_known_ || plausible(T_prev_curr, dt_s);
    if (ok) {
      step_ = T_prev_curr;
      step_known_ = true;
      T_W_R0_ = T_W_curr;
    }
  }
  if (ok) {
    r.source = PoseSource::kVision;
    reference_ = std::move(f);
    T_W_ref_ = T_W_R0_;
    reference_age_ = 0;
  } else {
    // No usable motion: the vehicle did not stop, so carry the last step (constant velocity)
    // instead of holding the pose, and keep matching against the last good frame while it
    // still overlaps.
    T_W_R0_ = T_W_R0_ * step_;
    r.source = PoseSource::kImuOnly;
    if (++reference_age_ >= params_.max_reference_age &&
        static_cast<int>(f.stereo.points.size()) >= params_.min_inliers) {
      reference_ = std::move(f);
      T_W_ref_ = T_W_R0_;
      reference_age_ = 0;
      step_known_ = false;  // the gate's step is stale: let the next measured motion set it
    }
  }
  last_t_ns_ = r.t_ns;
  r.T_W_B = T_W_R0_ * T_R0_B;
  r.times.total_ms += timer.total_ms();
  return r;
}

}  // namespace seavio::tools
