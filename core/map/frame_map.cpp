#include "core/map/frame_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>
#include <utility>

namespace seavio::map {

namespace {

/// Heap bookkeeping per allocation (glibc malloc chunk header, rounded): memoryBytes counts it
/// so the figure tracks the resident size rather than the payload alone.
constexpr std::size_t kAllocOverhead = 16;

}  // namespace

bool packPoint(const Eigen::Vector3f& p, PackedPoint& out) {
  constexpr float kMax = static_cast<float>(std::numeric_limits<int16_t>::max());
  int16_t v[3];
  for (int k = 0; k < 3; ++k) {
    const float mm = std::round(p[k] * 1000.0f);
    if (!std::isfinite(mm) || std::abs(mm) > kMax) return false;
    v[k] = static_cast<int16_t>(mm);
  }
  out = PackedPoint{v[0], v[1], v[2]};
  return true;
}

std::vector<Eigen::Vector3f> MapFrame::points() const {
  if (packed_R0.empty()) return points_R0;
  std::vector<Eigen::Vector3f> out;
  out.reserve(packed_R0.size());
  for (const PackedPoint& q : packed_R0) out.push_back(unpackPoint(q));
  return out;
}

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

template <typename Fn>
void FrameMap::forEachInCells(const Eigen::Vector3d& position_W, int64_t reach, Fn&& fn) const {
  const double c = std::max(params_.selection_radius_m, 0.1);
  const int64_t cx = static_cast<int64_t>(std::floor(position_W.x() / c));
  const int64_t cy = static_cast<int64_t>(std::floor(position_W.y() / c));
  const int64_t cz = static_cast<int64_t>(std::floor(position_W.z() / c));
  for (int64_t dx = -reach; dx <= reach; ++dx)
    for (int64_t dy = -reach; dy <= reach; ++dy)
      for (int64_t dz = -reach; dz <= reach; ++dz) {
        const auto it = grid_.find(keyOf(cx + dx, cy + dy, cz + dz));
        if (it == grid_.end()) continue;
        for (uint32_t idx : it->second) fn(idx);
      }
}

template <typename Fn>
void FrameMap::forEachNearby(const Eigen::Vector3d& position_W, Fn&& fn) const {
  // Cells are one selection radius wide, so the 27 around the query hold every keyframe
  // within that radius (and within any smaller one, such as the overlap radius).
  forEachInCells(position_W, 1, std::forward<Fn>(fn));
}

const MapFrame* FrameMap::coveringKeyframe(const Eigen::Isometry3d& T_W_R0) const {
  const double r = std::min(params_.overlap_radius_m, std::max(params_.selection_radius_m, 0.1));
  if (!(r > 0.0) || frames_.empty()) return nullptr;
  const Eigen::Vector3d p = T_W_R0.translation();
  // Optical axes: a rotation about the axis of a (near) nadir camera keeps the same patch of
  // floor in view, so only the axis direction decides coverage, not the heading.
  const Eigen::Vector3d axis = T_W_R0.linear().col(2);
  const double min_cos = std::cos(params_.keyframe_angle_rad);
  const MapFrame* best = nullptr;
  double best_d2 = r * r;
  forEachNearby(p, [&](uint32_t idx) {
    const MapFrame& f = frames_[idx];
    const double d2 = (f.T_W_R0.translation() - p).squaredNorm();
    if (d2 > best_d2 || (d2 == best_d2 && best != nullptr)) return;
    if (f.T_W_R0.linear().col(2).dot(axis) < min_cos) return;
    best = &f;
    best_d2 = d2;
  });
  return best;
}

bool FrameMap::wantsKeyframe(const Eigen::Isometry3d& T_W_R0) const {
  if (frames_.empty()) return true;
  const Eigen::Isometry3d& last = frames_.back().T_W_R0;
  const double d = (T_W_R0.translation() - last.translation()).norm();
  const double a = Eigen::AngleAxisd(last.rotation().transpose() * T_W_R0.rotation()).angle();
  if (d < params_.keyframe_distance_m && a < params_.keyframe_angle_rad) return false;
  return coveringKeyframe(T_W_R0) == nullptr;
}

void FrameMap::insert(MapFrame frame) {
  const std::size_t cap = static_cast<std::size_t>(std::max(params_.max_points_per_frame, 1));
  if (frame.packed_R0.empty()) {
    frame.packed_R0.reserve(std::min(cap, frame.points_R0.size()));
    PackedPoint q;
    for (const Eigen::Vector3f& p : frame.points_R0) {
      if (frame.packed_R0.size() >= cap) break;
      if (packPoint(p, q)) frame.packed_R0.push_back(q);
    }
  } else if (frame.packed_R0.size() > cap) {
    frame.packed_R0.resize(cap);
  }
  // Release the float input: the packed copy is the stored form.
  std::vector<Eigen::Vector3f>().swap(frame.points_R0);
  frame.packed_R0.shrink_to_fit();
  point_count_ += frame.packed_R0.size();
  grid_[keyOf(frame.T_W_R0.translation())].push_back(static_cast<uint32_t>(frames_.size()));
  frames_.push_back(std::move(frame));
}

std::vector<const MapFrame*> FrameMap::selectNear(const Eigen::Vector3d& position_W) const {
  std::vector<const MapFrame*> out;
  selectNear(position_W, out);
  return out;
}

void FrameMap::selectNear(const Eigen::Vector3d& position_W, std::vector<const MapFrame*>& out) const {
  out.clear();
  const double r2 = params_.selection_radius_m * params_.selection_radius_m;
  const auto d2 = [&](const MapFrame* f) { return (f->T_W_R0.translation() - position_W).squaredNorm(); };
  forEachNearby(position_W, [&](uint32_t idx) {
    if (d2(&frames_[idx]) <= r2) out.push_back(&frames_[idx]);
  });
  // nearestFirst's order without its (distance, frame) pairs: the distances are recomputed
  // (the same arithmetic, so the same order), which saves a buffer.
  std::sort(out.begin(), out.end(), [&](const MapFrame* a, const MapFrame* b) {
    const double da = d2(a), db = d2(b);
    return da < db || (da == db && a->id < b->id);
  });
  const std::size_t cap = static_cast<std::size_t>(std::max(params_.max_selected_frames, 0));
  if (out.size() > cap) out.resize(cap);
}

std::vector<const MapFrame*> FrameMap::nearestFirst(std::vector<std::pair<double, const MapFrame*>>& found,
                                                    std::size_t cap) {
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
    return a.first < b.first || (a.first == b.first && a.second->id < b.second->id);
  });
  if (found.size() > cap) found.resize(cap);
  std::vector<const MapFrame*> out;
  out.reserve(found.size());
  for (const auto& f : found) out.push_back(f.second);
  return out;
}

std::vector<const MapFrame*> FrameMap::selectWithin(const Eigen::Vector3d& position_W, double radius_m) const {
  std::vector<std::pair<double, const MapFrame*>> found;
  if (!(radius_m >= 0.0) || !position_W.allFinite()) return {};
  const double c = std::max(params_.selection_radius_m, 0.1);
  // Cells one selection radius wide: ceil(r / c) cells each way hold every keyframe within r.
  // The reach is bounded so that a runaway radius cannot turn a query into a scan of the
  // whole grid's key space; beyond it every stored keyframe is tested directly.
  const double reach_cells = std::ceil(radius_m / c);
  const double r2 = radius_m * radius_m;
  const auto test = [&](uint32_t idx) {
    const MapFrame& f = frames_[idx];
    const double d2 = (f.T_W_R0.translation() - position_W).squaredNorm();
    if (d2 <= r2) found.emplace_back(d2, &f);
  };
  const double cells_visited = std::pow(2.0 * reach_cells + 1.0, 3.0);
  if (cells_visited > static_cast<double>(frames_.size())) {
    for (uint32_t idx = 0; idx < frames_.size(); ++idx) test(idx);
  } else {
    forEachInCells(position_W, static_cast<int64_t>(reach_cells), test);
  }
  return nearestFirst(found, found.size());
}

ModelCloud FrameMap::buildModel(const std::vector<const MapFrame*>& frames) const {
  ModelCloud model;
  std::unordered_set<int64_t> occupied;
  const double v = std::max(params_.voxel_size_m, 1e-4);
  const auto add = [&](const Eigen::Vector3f& pw) {
    const int64_t key = keyOf(static_cast<int64_t>(std::floor(pw.x() / v)), static_cast<int64_t>(std::floor(pw.y() / v)),
                              static_cast<int64_t>(std::floor(pw.z() / v)));
    if (occupied.insert(key).second) model.points_W.push_back(pw);
  };
  for (const MapFrame* f : frames) {
    model.frame_ids.push_back(f->id);
    const Eigen::Isometry3f T = f->T_W_R0.cast<float>();
    // Frames from this map hold packed points; a caller's own frame may still hold floats.
    if (!f->packed_R0.empty()) {
      for (const PackedPoint& q : f->packed_R0) add(T * unpackPoint(q));
    } else {
      for (const Eigen::Vector3f& p : f->points_R0) add(T * p);
    }
  }
  return model;
}

std::size_t FrameMap::memoryBytes() const {
  std::size_t bytes = frames_.capacity() * sizeof(MapFrame);
  for (const MapFrame& f : frames_) {
    if (f.packed_R0.capacity() > 0) bytes += f.packed_R0.capacity() * sizeof(PackedPoint) + kAllocOverhead;
    if (f.points_R0.capacity() > 0) bytes += f.points_R0.capacity() * sizeof(Eigen::Vector3f) + kAllocOverhead;
  }
  for (const auto& [key, indices] : grid_)
    bytes += sizeof(key) + sizeof(indices) + 2 * sizeof(void*) + kAllocOverhead +  // hash node + bucket
             indices.capacity() * sizeof(uint32_t) + kAllocOverhead;
  return bytes;
}

std::size_t FrameMap::maxBytesPerKeyframe() const {
  const std::size_t cap = static_cast<std::size_t>(std::max(params_.max_points_per_frame, 1));
  // Vector growth at most doubles the frame array and a cell's index list; at worst every
  // keyframe opens a cell of its own.
  return 2 * sizeof(MapFrame) + cap * sizeof(PackedPoint) + kAllocOverhead + 2 * sizeof(uint32_t) +
         sizeof(CellKey) + sizeof(std::vector<uint32_t>) + 2 * sizeof(void*) + 2 * kAllocOverhead;
}

}  // namespace seavio::map
