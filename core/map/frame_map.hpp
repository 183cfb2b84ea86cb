#pragma once
/// The rough global map of paper section III-D: past keyframes with their poses and 3D
/// points, indexed by position so that selecting the frames near a predicted position costs
/// O(1) on average however long the mission (a hash grid with cells of the selection radius).
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
  double voxel_size_m = 0.01;          ///< model cloud downsampling [m]
  int max_points_per_frame = 600;      ///< compact storage: strongest points only
};

/// One keyframe: pose of its rectified left camera and its points in that camera frame.
struct MapFrame {
  uint64_t id = 0;
  int64_t t_ns = 0;
  Eigen::Isometry3d T_W_R0 = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector3f> points_R0;
};

/// Model cloud assembled from selected frames, in W.
struct ModelCloud {
  std::vector<Eigen::Vector3f> points_W;
  std::vector<uint64_t> frame_ids;  ///< the frames it was built from
};

class FrameMap {
 public:
  explicit FrameMap(const FrameMapParams& params = {});

  /// True if `T_W_R0` is far enough from the last keyframe to be stored.
  bool wantsKeyframe(const Eigen::Isometry3d& T_W_R0) const;
  /// Stores a keyframe (keeps at most max_points_per_frame points, evenly subsampled).
  void insert(MapFrame frame);

  /// Keyframes within the selection radius of `position_W`, nearest first, capped.
  std::vector<const MapFrame*> selectNear(const Eigen::Vector3d& position_W) const;
  /// Union of the frames' points in W, voxel-downsampled.
  ModelCloud buildModel(const std::vector<const MapFrame*>& frames) const;

  std::size_t size() const { return frames_.size(); }
  std::size_t pointCount() const { return point_count_; }
  /// Bytes held by the stored points and index (for the memory report).
  std::size_t memoryBytes() const;
  const FrameMapParams& params() const { return params_; }

 private:
  using CellKey = int64_t;
  CellKey keyOf(const Eigen::Vector3d& p) const;
  CellKey keyOf(int64_t ix, int64_t iy, int64_t iz) const;

  FrameMapParams params_;
  std::vector<MapFrame> frames_;
  std::unordered_map<CellKey, std::vector<uint32_t>> grid_;  ///< cell -> indices into frames_
  std::size_t point_count_ = 0;
};

}  // namespace seavio::map
