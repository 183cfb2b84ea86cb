#include "core/matching/temporal_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/capacity.hpp"
#include "core/matching/descriptor_distance.hpp"

namespace seavio::matching {
namespace {

/// Uniform grid over the current left image so a window query touches few points. Flat
/// (a counting sort of the points by cell into the workspace): the points of a cell keep
/// their ascending order, so queries visit them exactly as a vector per cell would.
class PixelGrid {
 public:
  PixelGrid(const std::vector<StereoPoint>& pts, int width, int height, int cell_px, std::vector<int>& start,
            std::vector<int>& items)
      : cell_(cell_px),
        cols_(std::max(1, (width + cell_px - 1) / cell_px)),
        rows_(std::max(1, (height + cell_px - 1) / cell_px)),
        start_(start),
        items_(items) {
    const std::size_t cells = static_cast<std::size_t>(cols_ * rows_);
    start_.assign(cells + 1, 0);
    for (const StereoPoint& p : pts) ++start_[cellOf(p.uv_left) + 1];
    for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
    reserveWithHeadroom(items_, pts.size());
    items_.resize(pts.size());
    // start_[c] doubles as the fill cursor of cell c, then is shifted back.
    for (std::size_t i = 0; i < pts.size(); ++i)
      items_[static_cast<std::size_t>(start_[cellOf(pts[i].uv_left)]++)] = static_cast<int>(i);
    for (std::size_t c = cells; c > 0; --c) start_[c] = start_[c - 1];
    start_[0] = 0;
  }
  template <typename F>
  void query(const Eigen::Vector2d& c, double r, F&& f) const {
    const int x0 = std::clamp(static_cast<int>((c.x() - r) / cell_), 0, cols_ - 1);
    const int x1 = std::clamp(static_cast<int>((c.x() + r) / cell_), 0, cols_ - 1);
    const int y0 = std::clamp(static_cast<int>((c.y() - r) / cell_), 0, rows_ - 1);
    const int y1 = std::clamp(static_cast<int>((c.y() + r) / cell_), 0, rows_ - 1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const auto cell = static_cast<std::size_t>(y * cols_ + x);
        for (int k = start_[cell]; k < start_[cell + 1]; ++k) f(items_[static_cast<std::size_t>(k)]);
      }
  }

 private:
  std::size_t cellOf(const Eigen::Vector2f& uv) const {
    const int x = std::clamp(static_cast<int>(uv.x()) / cell_, 0, cols_ - 1);
    const int y = std::clamp(static_cast<int>(uv.y()) / cell_, 0, rows_ - 1);
    return static_cast<std::size_t>(y * cols_ + x);
  }
  int cell_, cols_, rows_;
  std::vector<int>& start_;
  std::vector<int>& items_;
};

}  // namespace

double predictionWindowPx(const camera::RectifiedRig& rig, double z_m, const Eigen::Matrix<double, 6, 6>& covariance,
                          const TemporalMatchParams& params) {
  // First-order image motion of a point at depth z: f * (dtheta + dt / z).
  const double sigma_rot = std::sqrt(std::max(0.0, covariance.topLeftCorner<3, 3>().trace()));
  const double sigma_trans = std::sqrt(std::max(0.0, covariance.bottomRightCorner<3, 3>().trace()));
  const double sigma_px = rig.f_px * (sigma_rot + sigma_trans / std::max(z_m, 0.1));
  return std::min(params.sigma_multiplier * sigma_px + params.min_window_px,
                  std::max(params.min_window_px, std::hypot(rig.width, rig.height)));
}

std::vector<TemporalMatch> matchTemporal(const StereoFeatures& prev, const StereoFeatures& curr,
                                         const camera::RectifiedRig& rig, const Eigen::Isometry3d& T_prev_curr,
                                         const Eigen::Matrix<double, 6, 6>& covariance,
                                         const TemporalMatchParams& params) {
  TemporalMatchWorkspace ws;
  std::vector<TemporalMatch> out;
  matchTemporal(prev, curr, rig, T_prev_curr, covariance, params, ws, out);
  return out;
}

void matchTemporal(const StereoFeatures& prev, const StereoFeatures& curr, const camera::RectifiedRig& rig,
                   const Eigen::Isometry3d& T_prev_curr, const Eigen::Matrix<double, 6, 6>& covariance,
                   const TemporalMatchParams& params, TemporalMatchWorkspace& ws, std::vector<TemporalMatch>& out) {
  out.clear();
  if (prev.points.empty() || curr.points.empty()) return;
  const float max_dist = descriptorThreshold(curr.descriptors, params.max_descriptor_distance);
  const Eigen::Isometry3d T_curr_prev = T_prev_curr.inverse();
  const PixelGrid grid(curr.points, rig.width, rig.height, 24, ws.cell_start, ws.cell_points);
  const double whole_image = std::hypot(rig.width, rig.height);

  // Best current candidate per previous point, and best previous per current (mutual check).
  std::vector<TemporalMatch>& best = ws.best;
  std::vector<float>& second = ws.second;
  std::vector<int>& best_prev_of_curr = ws.best_prev_of_curr;
  std::vector<float>& best_prev_dist = ws.best_prev_dist;
  reserveWithHeadroom(best, prev.points.size());
  reserveWithHeadroom(second, prev.points.size());
  reserveWithHeadroom(best_prev_of_curr, curr.points.size());
  reserveWithHeadroom(best_prev_dist, curr.points.size());
  best.assign(prev.points.size(), TemporalMatch{});
  second.assign(prev.points.size(), std::numeric_limits<float>::max());
  best_prev_of_curr.assign(curr.points.size(), -1);
  best_prev_dist.assign(curr.points.size(), std::numeric_limits<float>::max());

  for (std::size_t i = 0; i < prev.points.size(); ++i) {
    const StereoPoint& sp = prev.points[i];
    const Eigen::Vector3d p_curr = T_curr_prev * sp.p_R0.cast<double>();
    Eigen::Vector2d uv_l(sp.uv_left.cast<double>()), uv_r(sp.uv_right.cast<double>());
    double radius = whole_image;
    if (params.use_prediction) {
      if (p_curr.z() <= 0.05) continue;
      uv_l = rig.project(p_curr, 0);
      uv_r = rig.project(p_curr, 1);
      radius = predictionWindowPx(rig, p_curr.z(), covariance, params);
    }
    const int sign = prev.laplacian_sign.empty() ? -1 : prev.laplacian_sign[i];
    best[i].prev = static_cast<int>(i);
    best[i].distance = std::numeric_limits<float>::max();
    auto consider = [&](int j) {
      const StereoPoint& cp = curr.points[static_cast<std::size_t>(j)];
      if (params.use_prediction) {
        if ((cp.uv_left.cast<double>() - uv_l).squaredNorm() > radius * radius) return;
        if ((cp.uv_right.cast<double>() - uv_r).squaredNorm() > radius * radius) return;
      }
      const int csign = curr.laplacian_sign.empty() ? -1 : curr.laplacian_sign[static_cast<std::size_t>(j)];
      if (sign >= 0 && csign >= 0 && sign != csign) return;
      const float d = descriptorDistance(prev.descriptors, static_cast<int>(i), curr.descriptors, j);
      if (d < best[i].distance) {
        second[i] = best[i].distance;
        best[i].distance = d;
        best[i].curr = j;
      } else if (d < second[i]) {
        second[i] = d;
      }
      if (d < best_prev_dist[static_cast<std::size_t>(j)]) {
        best_prev_dist[static_cast<std::size_t>(j)] = d;
        best_prev_of_curr[static_cast<std::size_t>(j)] = static_cast<int>(i);
      }
    };
    if (params.use_prediction) {
      grid.query(uv_l, radius, consider);
    } else {
      for (std::size_t j = 0; j < curr.points.size(); ++j) consider(static_cast<int>(j));
    }
  }
  reserveWithHeadroom(out, prev.points.size());
  for (std::size_t i = 0; i < best.size(); ++i) {
    const TemporalMatch& m = best[i];
    if (m.curr < 0 || m.distance > max_dist) continue;
    if (second[i] < std::numeric_limits<float>::max() && m.distance > params.ratio * second[i]) continue;
    if (best_prev_of_curr[static_cast<std::size_t>(m.curr)] != static_cast<int>(i)) continue;
    out.push_back(m);
  }
}

}  // namespace seavio::matching
