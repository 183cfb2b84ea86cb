#include "core/odometry/pnp_baseline.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace seavio::odometry {

OdometryResult PnpBaseline::process(const StereoFrame& frame) {
  OdometryResult r;
  r.t_ns = frame.t_ns;
  r.seq = frame.seq;
  FrameFeatures f = frontend_.process(frame, params_.threshold, {});
  r.quality.features_left = static_cast<int>(f.left.keypoints.size());
  r.quality.stereo_matches = static_cast<int>(f.stereo.points.size());
  const Eigen::Isometry3d T_R0_B = frontend_.rig().T_B_R0.inverse();
  if (previous_) {
    matching::TemporalMatchParams exhaustive;
    exhaustive.use_prediction = false;
    const auto matches = matching::matchTemporal(previous_->stereo, f.stereo, frontend_.rig(),
                                                 Eigen::Isometry3d::Identity(),
                                                 Eigen::Matrix<double, 6, 6>::Identity(), exhaustive);
    r.quality.temporal_matches = static_cast<int>(matches.size());
    std::vector<cv::Point3f> object;
    std::vector<cv::Point2f> image;
    for (const auto& m : matches) {
      const auto& p = previous_->stereo.points[static_cast<std::size_t>(m.prev)].p_R0;
      const auto& uv = f.stereo.points[static_cast<std::size_t>(m.curr)].uv_left;
      object.emplace_back(p.x(), p.y(), p.z());
      image.emplace_back(uv.x(), uv.y());
    }
    const auto& rig = frontend_.rig();
    const cv::Matx33d K(rig.f_px, 0, rig.cx, 0, rig.f_px, rig.cy, 0, 0, 1);
    cv::Mat rvec, tvec;
    std::vector<int> inliers;
    bool ok = object.size() >= 6 &&
              cv::solvePnPRansac(object, image, K, cv::noArray(), rvec, tvec, false, params_.iterations,
                                 static_cast<float>(params_.reprojection_px), 0.999, inliers, cv::SOLVEPNP_ITERATIVE);
    ok = ok && static_cast<int>(inliers.size()) >= params_.min_inliers;
    r.quality.ransac_inliers = static_cast<int>(inliers.size());
    if (ok) {
      cv::Mat R;
      cv::Rodrigues(rvec, R);
      Eigen::Matrix3d Re;
      Eigen::Vector3d te;
      cv::cv2eigen(R, Re);
      cv::cv2eigen(tvec, te);
      Eigen::Isometry3d T_curr_prev = Eigen::Isometry3d::Identity();
      T_curr_prev.linear() = Re;
      T_curr_prev.translation() = te;
      T_W_R0_ = T_W_R0_ * T_curr_prev.inverse();
      r.source = PoseSource::kVision;
    } else {
      r.source = PoseSource::kImuOnly;  // no IMU here: the pose is simply held, flagged
    }
  }
  r.T_W_B = T_W_R0_ * T_R0_B;
  previous_ = std::move(f);
  return r;
}

}  // namespace seavio::odometry
