/// Odometry's patch stage (paper III-C, refined): the RANSAC's pixel correspondences aligned
/// again patch by patch, the reference points descriptor matching missed looked for where the
/// motion puts them, and the inliers chosen again from the refined pixels.
#include <numeric>

#include "core/common/capacity.hpp"
#include "core/odometry/odometry.hpp"
#include "core/odometry/pose_checks.hpp"

namespace seavio::odometry {

void Odometry::refineWithPatches(const FrameFeatures& frame, FrameTrack& t, OdometryResult& r) {
  const PreviousFrame& prev = *previous_;
  const bool on_keyframe = t.reference.on_keyframe;
  const matching::StereoFeatures& ref_features = *t.reference.features;
  const std::vector<matching::TemporalMatch>& temporal = work_.temporal;
  std::vector<geometry::QuadMatch>& quads = work_.quads;
  geometry::RansacResult& ransac = work_.ransac;
  const cv::Mat& ref_left = on_keyframe ? keyframe_->left_image : prev.features.left_image;
  const cv::Mat& ref_right = on_keyframe ? keyframe_->right_image : prev.features.right_image;
  ReferenceAlignments* cache = nullptr;
  if (on_keyframe) {
    if (!work_.keyframe_alignments.holds(keyframe_->id))
      work_.keyframe_alignments.reset(keyframe_->id, ref_features.points.size());
    cache = &work_.keyframe_alignments;
  }
  if (!params_.patch_reselect || static_cast<int>(ransac.inliers.size()) < params_.patch_reselect_min_inliers) {
    refinePatches(ref_features, ref_left, ref_right, frame, temporal, ransac.T_prev_curr, ransac.inliers, cache, quads);
    return;
  }
  std::vector<uint32_t>& all = work_.patch_indices;
  resizeWithHeadroom(all, quads.size());
  std::iota(all.begin(), all.end(), 0u);
  refinePatches(ref_features, ref_left, ref_right, frame, temporal, ransac.T_prev_curr, all, cache, quads);
  // The reference points descriptor matching missed, looked for where the motion puts them
  // (guided_tracks.hpp); judged below with the rest. They sit after `temporal`'s quads.
  r.quality.guided_tracks =
      trackUnmatched(ref_features, ref_left, ref_right, frame.left_image, frame.right_image, frontend_.rig(),
                     ransac.T_prev_curr, temporal, params_.patch, params_.guided_tracks, cache, work_.guided_used, quads);
  for (std::size_t i = 0; i < work_.guided_used.size(); ++i)
    if (work_.guided_used[i] == 2) work_.quad_reference.push_back(static_cast<uint32_t>(i));
  // The same RANSAC (threshold) that found the motion judges the refined pixels. If too
  // few pass, the first selection stands: its inliers were refined just as before.
  geometry::RansacResult& again = work_.reselected;
  again.T_prev_curr = ransac.T_prev_curr;
  again.iterations = ransac.iterations;
  (t.rescued ? rescue_ransac_ : ransac_).reselect(quads, again);
  const int need = t.rescued ? params_.rescue_min_inliers : params_.min_inliers;
  if (again.status == geometry::RansacStatus::kOk && static_cast<int>(again.inliers.size()) >= need &&
      finitePose(again.T_prev_curr))
    std::swap(ransac, again);
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

}  // namespace seavio::odometry
