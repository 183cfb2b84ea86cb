#include "core/map/frame_map.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace seavio::map {

FrameMap::FrameMap(const FrameMapParams& params) : params_(params) {}

FrameMap::CellKey FrameMap::keyOf(int64_t ix, int64_t iy, int64_t iz) const {
  // 21 bits per axis: +-1e6 cells of >= 0.1 m covers any survey.
  const auto wrap = [](int64_t v) { return static_cast<uint64_t>(v + (1 << 20)) & 0x1FFFFF; };
  return static_cast<CellKey>((wrap(ix) << 42) | (wrap(iy) << 21) | wrap(iz));
}

FrameMap::CellKey FrameMap::keyOf(const Eigen::Vector3d& p) const {
  const double c = std::max(params_.selection_radius_m, 0.1);
  return keyOf(static_cast<int64_t>(std::floor(p.x() / c)), static_cast<int64_t>(std::floor(p.y() / c)),
               static_cast<int64_t>(std::floor(p.z() / c)));
}

bool FrameMap::wantsKeyframe(const Eigen::Isometry3d& T_W_R0) const {
  if (frames_.empty()) return true;
  const Eigen::Isometry3d& last = frames_.back().T_W_R0;
  const double d = (T_W_R0.translation() - last.translation()).norm();
  const double a = Eigen::AngleAxisd(last.rotation().transpose() * T_W_R0.rotation()).angle();
  return d >= params_.keyframe_distance_m || a >= params_.keyframe_angle_rad;
}

void FrameMap::insert(MapFrame frame) {
  const std::size_t cap = static_cast<std::size_t>(std::max(params_.max_points_per_frame, 1));
  if (frame.points_R0.size() > cap) {
    std::vector<Eigen::Vector3f> kept;
    kept.reserve(cap);
    const double step = static_cast<double>(frame.points_R0.size()) / static_cast<double>(cap);
    for (std::size_t i = 0; i < cap; ++i) kept.push_back(frame.points_R0[static_cast<std::size_t>(i * step)]);
    frame.points_R0 = std::move(kept);
  }
  frame.points_R0.shrink_to_fit();
  point_count_ += frame.points_R0.size();
  grid_[keyOf(frame.T_W_R0.translation())].push_back(static_cast<uint32_t>(frames_.size()));
  frames_.push_back(std::move(frame));
}

std::vector<const MapFrame*> FrameMap::selectNear(const Eigen::Vector3d& position_W) const {
  std::vector<std::pair<double, const MapFrame*>> found;
  const double c = std::max(params_.selection_radius_m, 0.1);
  const double r2 = params_.selection_radius_m * params_.selection_radius_m;
  const int64_t cx = static_cast<int64_t>(std::floor(position_W.x() / c));
  const int64_t cy = static_cast<int64_t>(std::floor(position_W.y() / c));
  const int64_t cz = static_cast<int64_t>(std::floor(position_W.z() / c));
  for (int64_t dx = -1; dx <= 1; ++dx)
    for (int64_t dy = -1; dy <= 1; ++dy)
      for (int64_t dz = -1; dz <= 1; ++dz) {
        const auto it = grid_.find(keyOf(cx + dx, cy + dy, cz + dz));
        if (it == grid_.end()) continue;
        for (uint32_t idx : it->second) {
          const MapFrame& f = frames_[idx];
          const double d2 = (f.T_W_R0.translation() - position_W).squaredNorm();
          if (d2 <= r2) found.emplace_back(d2, &f);
        }
      }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
    return a.first < b.first || (a.first == b.first && a.second->id < b.second->id);
  });
  if (found.size() > static_cast<std::size_t>(std::max(params_.max_selected_frames, 0)))
    found.resize(static_cast<std::size_t>(std::max(params_.max_selected_frames, 0)));
  std::vector<const MapFrame*> out;
  out.reserve(found.size());
  for (const auto& f : found) out.push_back(f.second);
  return out;
}

ModelCloud FrameMap::buildModel(const std::vector<const MapFrame*>& frames) const {
  ModelCloud model;
  std::unordered_set<int64_t> occupied;
  const double v = std::max(params_.voxel_size_m, 1e-4);
  for (const MapFrame* f : frames) {
    model.frame_ids.push_back(f->id);
    const Eigen::Isometry3f T = f->T_W_R0.cast<float>();
    for (const Eigen::Vector3f& p : f->points_R0) {
      const Eigen::Vector3f pw = T * p;
      const int64_t key = keyOf(static_cast<int64_t>(std::floor(pw.x() / v)), static_cast<int64_t>(std::floor(pw.y() / v)),
                                static_cast<int64_t>(std::floor(pw.z() / v)));
      if (occupied.insert(key).second) model.points_W.push_back(pw);
    }
  }
  return model;
}

std::size_t FrameMap::memoryBytes() const {
  std::size_t bytes = frames_.capacity() * sizeof(MapFrame);
  for (const MapFrame& f : frames_) bytes += f.points_R0.capacity() * sizeof(Eigen::Vector3f);
  bytes += grid_.size() * (sizeof(CellKey) + sizeof(std::vector<uint32_t>) + 16);
  bytes += frames_.size() * sizeof(uint32_t);
  return bytes;
}

}  // namespace seavio::map
