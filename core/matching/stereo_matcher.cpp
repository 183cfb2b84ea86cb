#include "core/matching/stereo_matcher.hpp"

#include <algorithm>
#include <limits>
#include <numeric>

#include "core/common/capacity.hpp"
#include "core/matching/descriptor_distance.hpp"

namespace seavio::matching {

float descriptorThreshold(const cv::Mat& descriptors, float max_descriptor_distance) {
  if (descriptors.type() == CV_32F) return max_descriptor_distance;
  // A binary descriptor of n bits: about max/0.7 of the bits may differ for the same
  // tolerance as a unit-norm float descriptor (empirical correspondence).
  return max_descriptor_distance / 0.7f * 0.5f * static_cast<float>(descriptors.cols * 8);
}

namespace {

bool sameLaplacianSign(const cv::KeyPoint& a, const cv::KeyPoint& b) {
  return a.class_id == b.class_id || a.class_id < 0 || b.class_id < 0;
}

using Best = StereoMatchWorkspace::Best;

}  // namespace

std::vector<StereoPoint> matchStereo(const std::vector<cv::KeyPoint>& left, const cv::Mat& left_descriptors,
                                     const std::vector<cv::KeyPoint>& right, const cv::Mat& right_descriptors,
                                     const camera::RectifiedRig& rig, const StereoMatchParams& params) {
  StereoMatchWorkspace ws;
  std::vector<StereoPoint> out;
  matchStereo(left, left_descriptors, right, right_descriptors, rig, params, ws, out);
  return out;
}

void matchStereo(const std::vector<cv::KeyPoint>& left, const cv::Mat& left_descriptors,
                 const std::vector<cv::KeyPoint>& right, const cv::Mat& right_descriptors,
                 const camera::RectifiedRig& rig, const StereoMatchParams& params, StereoMatchWorkspace& ws,
                 std::vector<StereoPoint>& out) {
  out.clear();
  if (left.empty() || right.empty() || rig.f_px <= 0 || rig.baseline_m <= 0) return;
  const DisparityWindow window = disparityWindow(rig, params);
  const double d_min = window.min_px, d_max = window.max_px;
  const float max_dist = descriptorThreshold(left_descriptors, params.max_descriptor_distance);
  const float row_tol = static_cast<float>(params.max_row_difference_px);

  // Right keypoints sorted by row so each left keypoint scans only a thin band.
  std::vector<int>& by_row = ws.by_row;
  resizeWithHeadroom(by_row, right.size());
  std::iota(by_row.begin(), by_row.end(), 0);
  std::sort(by_row.begin(), by_row.end(), [&](int a, int b) { return right[a].pt.y < right[b].pt.y; });
  std::vector<float>& rows = ws.rows;
  resizeWithHeadroom(rows, by_row.size());
  for (std::size_t i = 0; i < by_row.size(); ++i) rows[i] = right[by_row[i]].pt.y;

  auto candidates = [&](float y) {
    const auto lo = std::lower_bound(rows.begin(), rows.end(), y - row_tol) - rows.begin();
    const auto hi = std::upper_bound(rows.begin(), rows.end(), y + row_tol) - rows.begin();
    return std::pair<std::ptrdiff_t, std::ptrdiff_t>{lo, hi};
  };

  std::vector<Best>& best_left = ws.best_left;
  std::vector<Best>& best_right = ws.best_right;
  best_left.assign(left.size(), Best{});
  best_right.assign(right.size(), Best{});
  for (std::size_t l = 0; l < left.size(); ++l) {
    const cv::KeyPoint& kl = left[l];
    const auto [lo, hi] = candidates(kl.pt.y);
    for (auto k = lo; k < hi; ++k) {
      const int r = by_row[static_cast<std::size_t>(k)];
      const cv::KeyPoint& kr = right[r];
      const double d = kl.pt.x - kr.pt.x;
      if (d < d_min || d > d_max || !sameLaplacianSign(kl, kr)) continue;
      const float dist = descriptorDistance(left_descriptors, static_cast<int>(l), right_descriptors, r);
      best_left[l].offer(r, dist);
      best_right[r].offer(static_cast<int>(l), dist);
    }
  }
  out.reserve(left.size() / 2);
  for (std::size_t l = 0; l < left.size(); ++l) {
    const Best& b = best_left[l];
    if (b.index < 0 || b.distance > max_dist) continue;
    if (b.second < std::numeric_limits<float>::max() && b.distance > params.ratio * b.second) continue;
    if (params.left_right_check && best_right[b.index].index != static_cast<int>(l)) continue;
    const cv::KeyPoint& kl = left[l];
    const cv::KeyPoint& kr = right[b.index];
    StereoPoint sp;
    sp.left_index = static_cast<int>(l);
    sp.right_index = b.index;
    sp.uv_left = {kl.pt.x, kl.pt.y};
    sp.uv_right = {kr.pt.x, kr.pt.y};
    // Rows agree to sub-pixel after rectification; use their mean for the vertical ray.
    const Eigen::Vector2d uv(kl.pt.x, 0.5 * (kl.pt.y + kr.pt.y));
    sp.p_R0 = rig.triangulate(uv, static_cast<double>(kl.pt.x - kr.pt.x)).cast<float>();
    if (!sp.p_R0.allFinite()) continue;
    out.push_back(sp);
  }
}

}  // namespace seavio::matching
