#include "core/matching/stereo_completion.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace seavio::matching {

namespace {
constexpr int kMaxNeighbours = 16;
struct Neighbour {
  float distance2_px2, disparity_px;
};
}  // namespace

int completeStereo(const std::vector<cv::KeyPoint>& left, const cv::Mat& left_image, const cv::Mat& right_image,
                   const camera::RectifiedRig& rig, const StereoMatchParams& stereo, StereoCompletionWorkspace& ws,
                   std::vector<StereoPoint>& points) {
  const StereoCompletionParams& p = stereo.completion;
  if (!p.enabled || left_image.empty() || right_image.empty() || points.empty() || rig.f_px <= 0 ||
      rig.baseline_m <= 0)
    return 0;
  if (static_cast<double>(points.size()) >= p.max_matched_share * static_cast<double>(left.size())) return 0;
  const int wanted = std::clamp(p.neighbours, 1, kMaxNeighbours);
  const std::size_t n_matched = points.size();
  ws.matched.assign(left.size(), 0);
  ws.by_row.resize(n_matched);
  for (std::size_t i = 0; i < n_matched; ++i) {
    ws.by_row[i] = static_cast<int>(i);
    const int l = points[i].left_index;
    if (l >= 0 && static_cast<std::size_t>(l) < left.size()) ws.matched[static_cast<std::size_t>(l)] = 1;
  }
  const auto row = [&](int i) { return points[static_cast<std::size_t>(i)].uv_left.y(); };
  std::sort(ws.by_row.begin(), ws.by_row.end(), [&](int a, int b) { return row(a) < row(b); });
  const DisparityWindow window = disparityWindow(rig, stereo);
  const double d_min = window.min_px, d_max = window.max_px;
  const float reach = static_cast<float>(p.max_neighbour_distance_px);
  const float separation2 = static_cast<float>(p.min_separation_px * p.min_separation_px);
  const float offsets[3] = {0.f, -static_cast<float>(p.start_spacing_px), static_cast<float>(p.start_spacing_px)};
  std::array<Neighbour, kMaxNeighbours> near{};
  std::array<float, kMaxNeighbours> disparities{};
  int added = 0;
  for (std::size_t k = 0; k < left.size(); ++k) {
    if (ws.matched[k]) continue;
    const Eigen::Vector2f uv(left[k].pt.x, left[k].pt.y);
    // The `wanted` nearest matched points within `reach`, by insertion (a handful at most).
    int count = 0;
    const auto first = std::lower_bound(ws.by_row.begin(), ws.by_row.end(), uv.y() - reach,
                                        [&](int i, float y) { return row(i) < y; });
    for (auto it = first; it != ws.by_row.end(); ++it) {
      const StereoPoint& m = points[static_cast<std::size_t>(*it)];
      if (m.uv_left.y() > uv.y() + reach) break;
      const float d2 = (m.uv_left - uv).squaredNorm();
      if (d2 > reach * reach) continue;
      if (count == wanted && d2 >= near[static_cast<std::size_t>(count - 1)].distance2_px2) continue;
      int j = std::min(count, wanted - 1);
      while (j > 0 && near[static_cast<std::size_t>(j - 1)].distance2_px2 > d2) {
        near[static_cast<std::size_t>(j)] = near[static_cast<std::size_t>(j - 1)];
        --j;
      }
      near[static_cast<std::size_t>(j)] = {d2, m.uv_left.x() - m.uv_right.x()};
      count = std::min(count + 1, wanted);
    }
    if (count < wanted || near[0].distance2_px2 < separation2) continue;
    for (int j = 0; j < count; ++j)
      disparities[static_cast<std::size_t>(j)] = near[static_cast<std::size_t>(j)].disparity_px;
    std::sort(disparities.begin(), disparities.begin() + count);
    if (disparities[static_cast<std::size_t>(count - 1)] - disparities[0] > p.max_disparity_spread_px) continue;
    const float predicted = disparities[static_cast<std::size_t>(count / 2)];

    const PatchTemplate tmpl = makePatchTemplate(left_image, uv, p.patch);
    if (!tmpl.ok) continue;
    PatchAlignment best;
    for (const float offset : offsets) {
      const Eigen::Vector2f start(uv.x() - predicted + offset, uv.y());
      const PatchAlignment a = alignPatch(tmpl, right_image, start, Eigen::Matrix2f::Identity(), p.patch);
      const bool on_row = std::abs(a.uv.y() - uv.y()) <= p.max_row_difference_px;
      if (a.ok && on_row && (!best.ok || a.zncc > best.zncc)) best = a;
    }
    if (!best.ok) continue;
    const double disparity = static_cast<double>(uv.x() - best.uv.x());
    if (disparity < d_min || disparity > d_max) continue;
    StereoPoint sp;
    sp.left_index = static_cast<int>(k);
    sp.right_index = -1;
    sp.uv_left = uv;
    sp.uv_right = best.uv;
    sp.p_R0 = rig.triangulate(uv.cast<double>(), disparity).cast<float>();
    points.push_back(sp);
    ++added;
  }
  return added;
}

}  // namespace seavio::matching
