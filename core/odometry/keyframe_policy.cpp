/// The keyframe policy (local mode, paper III-C against a keyframe): frames are tracked
/// against one keyframe while it still overlaps them well, so the motion's error does not add
/// up frame by frame; when the overlap thins, the frame becomes the keyframe.
#include "core/odometry/odometry.hpp"

namespace seavio::odometry {

void Odometry::updateKeyframe(const FrameFeatures& frame, const FrameTrack& t, const OdometryResult& r) {
  const bool on_keyframe = t.reference.on_keyframe;
  const bool visual = r.source == PoseSource::kVision;
  const int inliers = r.quality.ransac_inliers;
  if (on_keyframe && visual && keyframe_->first_inliers == 0) keyframe_->first_inliers = inliers;
  const bool keep = on_keyframe && visual && inliers >= params_.keyframe_min_inliers &&
                    inliers >= params_.keyframe_min_inlier_ratio * keyframe_->first_inliers &&
                    (keyframe_->T_W_R0.inverse() * t.T_W_R0).translation().norm() <= params_.keyframe_max_distance_m;
  if (!keep) {
    newKeyframe(frame, t.T_W_R0, r.t_ns);
    return;
  }
  keyframe_->R_kf_prev_gyro = t.reference.R_ref_curr_gyro;
  keyframe_->gyro_covariance = t.reference.gyro_covariance + t.prediction.covariance.topLeftCorner<3, 3>();
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

}  // namespace seavio::odometry
