/// Odometry's registration stage (paper III-D/E): the frame's stereo cloud aligned by ICP
/// against the reference (local) or against the map of frames near it (global), and the
/// accepted frames' clouds kept in that map.
#include "core/common/capacity.hpp"
#include "core/odometry/odometry.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {

void Odometry::buildPointIndex(const matching::StereoFeatures& features, std::vector<Eigen::Vector3f>& scratch,
                               icp::PointCloudIndex& index) {
  scratch.clear();
  reserveWithHeadroom(scratch, features.points.size());
  for (const auto& sp : features.points) scratch.push_back(sp.p_R0);
  index.build(scratch);
}

void Odometry::fillCloud(const FrameFeatures& frame) {
  std::vector<Eigen::Vector3f>& data = work_.cloud;
  data.clear();
  reserveWithHeadroom(data, frame.stereo.points.size());
  for (const auto& sp : frame.stereo.points) data.push_back(sp.p_R0);
}

void Odometry::registerFrame(const FrameFeatures& frame, FrameTrack& t, OdometryResult& r) {
  fillCloud(frame);
  if (!t.vision_ok) return;
  if (params_.mode == Mode::kLocal) {
    alignToReference(work_.cloud, t, r);
  } else if (!deferred_) {
    alignToMap(frame, work_.cloud, t, r);
  }
}

void Odometry::alignToReference(const std::vector<Eigen::Vector3f>& data, FrameTrack& t, OdometryResult& r) {
  const matching::StereoFeatures& ref_features = *t.reference.features;
  // The keyframe's tree was built with it; only a frame tracked against the previous frame
  // (no keyframe, or the keyframe lost) builds one, and that allocates (nanoflann's pool).
  const icp::PointCloudIndex* index = t.reference.on_keyframe ? &keyframe_->model_index : nullptr;
  if (!index || index->size() != ref_features.points.size()) {
    buildPointIndex(ref_features, work_.model, work_.previous_index);
    index = &work_.previous_index;
  }
  const std::vector<Eigen::Vector3f>& model = index->points();
  std::vector<std::pair<int, int>>& seeds = work_.seeds;
  seeds.clear();
  reserveWithHeadroom(seeds, work_.ransac.inliers.size());
  for (uint32_t i : work_.ransac.inliers)  // guided tracks (past `temporal`) have no current stereo point
    if (i < work_.temporal.size()) seeds.emplace_back(work_.temporal[i].curr, work_.temporal[i].prev);
  const icp::IcpResult icp = icp::alignIcp(data, model, *index, seeds, t.T_ref_curr, params_.icp, work_.icp);
  r.quality.icp_iterations = icp.iterations;
  r.quality.icp_inliers = icp.inliers;
  r.quality.icp_rms_m = icp.rms_m;
  r.quality.model_points = static_cast<int>(model.size());
  if (icp.status == icp::IcpStatus::kOk && params_.final_stage == FinalStage::kIcp && finitePose(icp.T_model_data)) {
    t.T_ref_curr = icp.T_model_data;
    t.T_W_R0 = t.reference.T_W_ref * t.T_ref_curr;
  }
}

void Odometry::alignToMap(const FrameFeatures& frame, const std::vector<Eigen::Vector3f>& data, FrameTrack& t,
                          OdometryResult& r) {
  // The global step inline (GlobalRefiner::correct); keyframes are inserted once the frame
  // passed the speed check (insertIntoMap).
  const GlobalCorrection g = refiner_.correct(frame.stereo, data, frame.seq, frame.t_ns, t.T_W_R0, pose_covariance_,
                                              rng_);
  if (g.changed()) {
    t.map_shift_W = g.T_W_R0.translation() - t.T_W_R0.translation();
    t.map_delta_W = g.T_W_R0 * t.T_W_R0.inverse();
    t.T_W_R0 = g.T_W_R0;
  }
  if (g.revisit_used) t.inline_revisit = g;
  r.quality.model_points = g.model_points;
  r.quality.map_refined = g.changed();
  if (g.icp_ran) {
    r.quality.icp_iterations = g.icp_iterations;
    r.quality.icp_inliers = g.icp_inliers;
    r.quality.icp_rms_m = g.icp_rms_m;
  }
}

void Odometry::insertIntoMap(const FrameFeatures& frame, const Eigen::Isometry3d& T_W_R0, const OdometryResult& r,
                             bool first_frame) {
  if (deferred_) {
    makeGlobalRequest(frame, T_W_R0, r, first_frame);
    return;
  }
  // The cloud is kept for the next frame: the map gets a copy only when it stores one.
  std::vector<Eigen::Vector3f> points;
  if (first_frame || refiner_.frameMap().wantsKeyframe(T_W_R0)) points = work_.cloud;
  refiner_.insertKeyframe(frame.seq, frame.t_ns, T_W_R0, std::move(points), frame.stereo,
                          pose_covariance_.bottomRightCorner<3, 3>().trace(), first_frame);
}

}  // namespace seavio::odometry
