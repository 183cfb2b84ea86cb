#include "core/odometry/guided_tracks.hpp"

namespace seavio::odometry {

int trackUnmatched(const matching::StereoFeatures& ref, const cv::Mat& ref_left, const cv::Mat& ref_right,
                   const cv::Mat& curr_left, const cv::Mat& curr_right, const camera::RectifiedRig& rig,
                   const Eigen::Isometry3d& T_ref_curr, std::span<const matching::TemporalMatch> matched,
                   const matching::PatchAlignParams& patch, const GuidedTrackParams& params,
                   ReferenceAlignments* cache, std::vector<uint8_t>& used, std::vector<geometry::QuadMatch>& quads) {
  if (!params.enabled || ref_left.empty() || ref_right.empty() || curr_left.empty() || curr_right.empty()) return 0;
  used.assign(ref.points.size(), 0);
  for (const auto& m : matched)
    if (m.prev >= 0 && static_cast<std::size_t>(m.prev) < used.size()) used[static_cast<std::size_t>(m.prev)] = 1;
  const Eigen::Isometry3d T_curr_ref = T_ref_curr.inverse();
  const Eigen::Matrix2f turn = matching::inPlaneTurn(T_ref_curr.rotation());
  const double w = static_cast<double>(curr_left.cols), h = static_cast<double>(curr_left.rows);
  const auto inside = [&](const Eigen::Vector2d& uv) {
    return uv.x() >= params.border_px && uv.y() >= params.border_px && uv.x() < w - params.border_px &&
           uv.y() < h - params.border_px;
  };
  int added = 0;
  for (std::size_t i = 0; i < ref.points.size(); ++i) {
    if (used[i]) continue;
    const matching::StereoPoint& a = ref.points[i];
    if (!(a.p_R0.z() > 0)) continue;
    const Eigen::Vector3d p_curr = T_curr_ref * a.p_R0.cast<double>();
    if (!(p_curr.z() > 0)) continue;
    const Eigen::Vector2d uv_l = rig.project(p_curr, 0), uv_r = rig.project(p_curr, 1);
    if (!inside(uv_l) || !inside(uv_r)) continue;
    if (cache && cache->knownToFail(i)) continue;
    const matching::PatchTemplate tmpl = matching::makePatchTemplate(ref_left, a.uv_left, patch);
    Eigen::Vector2f uv_right;
    if (!alignInReferenceRight(i, tmpl, ref_right, a.uv_right, patch, cache, uv_right)) continue;
    const Eigen::Matrix2f A = static_cast<float>(a.p_R0.z() / p_curr.z()) * turn;
    const auto lc = matching::alignPatch(tmpl, curr_left, uv_l.cast<float>(), A, patch);
    if (!lc.ok) continue;
    const auto rc = matching::alignPatch(tmpl, curr_right, uv_r.cast<float>(), A, patch);
    if (!rc.ok) continue;
    quads.push_back(geometry::QuadMatch{a.uv_left, uv_right, lc.uv, rc.uv});
    used[i] = 2;
    ++added;
  }
  return added;
}

}  // namespace seavio::odometry
