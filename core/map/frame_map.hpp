#pragma once
/// The rough global map of paper section III-D: past keyframes with their poses and 3D
/// points, indexed by position so that selecting the frames near a predicted position costs
/// O(1) on average however long the mission (a hash grid with cells of the selection radius).
///
/// Memory grows with the area surveyed, not with the time spent over it: a
/// new keyframe is taken only after some travel or rotation AND where no stored keyframe
/// already covers the view, and points are stored as int16 millimetres in the keyframe's
/// camera frame (6 bytes a point instead of 12), strongest first, capped per keyframe.
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace seavio::map {

struct FrameMapParams {
  double selection_radius_m = 2.5;     ///< frames whose camera is this close are selected [m]
  int max_selected_frames = 12;        ///< cap on the model size (nearest first)
  double keyframe_distance_m = 0.4;    ///< a new keyframe after this much travel [m]...
  double keyframe_angle_rad = 0.15;    ///< ...or this much rotation [rad]
  /// ...unless a stored keyframe whose camera is within this distance and whose optical axis
  /// is within keyframe_angle_rad of the new one already sees the same floor [m]; 0 disables.
  /// Must exceed half the keyframe spacing of earlier passes (1.5 m at the paper's 1 Hz), or
  /// every pass over mapped ground adds keyframes between the old ones.
  double overlap_radius_m = 1.0;
  double voxel_size_m = 0.01;          ///< model cloud downsampling [m]
  int max_points_per_frame = 600;      ///< compact storage: strongest points only
};

/// One stored map point: millimetres in the keyframe's rectified left camera frame R0. int16
/// covers +-32.7 m, far beyond stereo range underwater; the 0.5 mm rounding is two orders
/// below the stereo depth noise at survey altitude.
struct PackedPoint {
  int16_t x_mm = 0, y_mm = 0, z_mm = 0;
};

/// One keyframe: pose of its rectified left camera and its points in that camera frame.
struct MapFrame {
  uint64_t id = 0;
  int64_t t_ns = 0;
  Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
  /// Input: the frame's points in R0 [m], strongest first (the front end's order).
  /// FrameMap::insert moves them into `packed_R0` and releases this vector.
  std::vector<Eigen::Vector3f> points_R0;
  /// Stored form of the points (filled by FrameMap::insert).
  std::vector<PackedPoint> packed_R0{};

  /// Number of points, whichever form holds them.
  std::size_t pointCount() const { return packed_R0.empty() ? points_R0.size() : packed_R0.size(); }
  /// The points in R0 [m], decoded from the stored form (or the input form before insert).
  std::vector<Eigen::Vector3f> points() const;
};

/// Model cloud assembled from selected frames, in W.
struct ModelCloud {
  std::vector<Eigen::Vector3f> points_W;
  std::vector<uint64_t> frame_ids;  ///< the frames it was built from
};

/// Packs `p` [m] to millimetres; false (and `out` untouched) if a coordinate is not finite or
/// beyond the int16 range.
bool packPoint(const Eigen::Vector3f& p, PackedPoint& out);
/// Inverse of packPoint [m].
inline Eigen::Vector3f unpackPoint(const PackedPoint& q) {
  return Eigen::Vector3f(static_cast<float>(q.x_mm), static_cast<float>(q.y_mm), static_cast<float>(q.z_mm)) * 1e-3f;
}

class FrameMap {
 public:
  explicit FrameMap(const FrameMapParams& params = {});

  /// True if `T_W_R0` is far enough from the last keyframe (distance or angle) to be stored
  /// and no stored keyframe already covers its view (see FrameMapParams::overlap_radius_m).
  bool wantsKeyframe(const Eigen::Isometry3d& T_W_R0) const;
  /// The stored keyframe nearest to `T_W_R0` that covers its view, or nullptr.
  const MapFrame* coveringKeyframe(const Eigen::Isometry3d& T_W_R0) const;
  /// Stores a keyframe: keeps its first max_points_per_frame points (the strongest, given the
  /// front end's order) that fit the packed form, packs them and releases the float input.
  void insert(MapFrame frame);

  /// Keyframes within the selection radius of `position_W`, nearest first, capped.
  std::vector<const MapFrame*> selectNear(const Eigen::Vector3d& position_W) const;
  /// The same into `out` (cleared first): with a caller-owned `out`, no allocation once it has
  /// grown to the cap (this runs every frame in global mode).
  void selectNear(const Eigen::Vector3d& position_W, std::vector<const MapFrame*>& out) const;
  /// Every keyframe within `radius_m` of `position_W` (any radius: the grid cells it spans
  /// are visited), nearest first, uncapped. For the re-observation search, whose radius grows
  /// with the drift since the old ground was mapped.
  std::vector<const MapFrame*> selectWithin(const Eigen::Vector3d& position_W, double radius_m) const;
  /// Union of the frames' points in W, voxel-downsampled.
  ModelCloud buildModel(const std::vector<const MapFrame*>& frames) const;

  std::size_t size() const { return frames_.size(); }
  std::size_t pointCount() const { return point_count_; }
  /// Bytes held by the keyframes, their stored points and the index (for the memory report).
  std::size_t memoryBytes() const;
  /// Upper bound of memoryBytes() per keyframe for these params [bytes] (amortised, index
  /// and container slack included): what a keyframe can cost however many points it had.
  std::size_t maxBytesPerKeyframe() const;
  const FrameMapParams& params() const { return params_; }

 private:
  using CellKey = int64_t;
  CellKey keyOf(const Eigen::Vector3d& p) const;
  CellKey keyOf(int64_t ix, int64_t iy, int64_t iz) const;
  /// Calls fn(index) for every keyframe in the 27 grid cells around `position_W`.
  template <typename Fn>
  void forEachNearby(const Eigen::Vector3d& position_W, Fn&& fn) const;
  /// Calls fn(index) for every keyframe in the cells within `reach` cells of `position_W`'s.
  template <typename Fn>
  void forEachInCells(const Eigen::Vector3d& position_W, int64_t reach, Fn&& fn) const;
  /// Sorted nearest first (ties by id), cut to `cap`.
  static std::vector<const MapFrame*> nearestFirst(std::vector<std::pair<double, const MapFrame*>>& found,
                                                   std::size_t cap);

  FrameMapParams params_;
  std::vector<MapFrame> frames_;
  std::unordered_map<CellKey, std::vector<uint32_t>> grid_;  ///< cell -> indices into frames_
  std::size_t point_count_ = 0;
};

}  // namespace seavio::map
