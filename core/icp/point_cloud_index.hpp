#pragma once
/// kd-tree over a 3D point cloud (nanoflann), the nearest-neighbour search of the ICP
/// (paper section III-E suggests k-d trees for exactly this; the paper's own arrays were O(n)).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace seavio::icp {

/// Owns a copy of the points and a kd-tree over them. Movable, not copyable; queries are const
/// and may run concurrently from several threads.
class PointCloudIndex {
 public:
  PointCloudIndex();
  /// Builds the tree over `points` [m], any frame.
  explicit PointCloudIndex(std::vector<Eigen::Vector3f> points);
  ~PointCloudIndex();
  PointCloudIndex(PointCloudIndex&&) noexcept;
  PointCloudIndex& operator=(PointCloudIndex&&) noexcept;
  PointCloudIndex(const PointCloudIndex&) = delete;
  PointCloudIndex& operator=(const PointCloudIndex&) = delete;

  /// Replaces the cloud and rebuilds the tree; reuses the point storage when it is big enough.
  void build(std::span<const Eigen::Vector3f> points);

  [[nodiscard]] std::size_t size() const;
  [[nodiscard]] const std::vector<Eigen::Vector3f>& points() const;

  /// Nearest point to `query`; false on an empty cloud or a non-finite query.
  /// @param dist_sq squared distance [m^2]
  bool nearest(const Eigen::Vector3f& query, uint32_t& index, float& dist_sq) const;
  /// Up to k nearest points, closest first; returns how many were written to the spans
  /// (at most min(k, size, span sizes)). Distances are squared [m^2].
  std::size_t knn(const Eigen::Vector3f& query, std::size_t k, std::span<std::size_t> indices,
                  std::span<float> dist_sq) const;
  /// All points within `radius_m` of `query`, sorted by distance; `out` holds
  /// (index, squared distance [m^2]) and is cleared first. Returns the count.
  std::size_t radius(const Eigen::Vector3f& query, float radius_m,
                     std::vector<std::pair<std::size_t, float>>& out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace seavio::icp
