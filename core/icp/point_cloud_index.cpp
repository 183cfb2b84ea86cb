#include "core/icp/point_cloud_index.hpp"

#include <algorithm>

#include <nanoflann.hpp>

namespace seavio::icp {
namespace {

/// nanoflann's dataset adaptor over the owned points.
struct CloudAdaptor {
  const std::vector<Eigen::Vector3f>* pts = nullptr;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*pts)[i][int(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, CloudAdaptor>,
                                                 CloudAdaptor, 3, std::size_t>;

}  // namespace

struct PointCloudIndex::Impl {
  std::vector<Eigen::Vector3f> points;
  CloudAdaptor adaptor;
  std::unique_ptr<Tree> tree;
  Impl() { adaptor.pts = &points; }
  void rebuild() {
    adaptor.pts = &points;
    if (!tree) {
      tree = std::make_unique<Tree>(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    } else {
      tree->buildIndex();
    }
  }
};

PointCloudIndex::PointCloudIndex() : impl_(std::make_unique<Impl>()) { impl_->rebuild(); }

PointCloudIndex::PointCloudIndex(std::vector<Eigen::Vector3f> points)
    : impl_(std::make_unique<Impl>()) {
  impl_->points = std::move(points);
  impl_->rebuild();
}

PointCloudIndex::~PointCloudIndex() = default;
PointCloudIndex::PointCloudIndex(PointCloudIndex&&) noexcept = default;
PointCloudIndex& PointCloudIndex::operator=(PointCloudIndex&&) noexcept = default;

void PointCloudIndex::build(std::span<const Eigen::Vector3f> points) {
  if (!impl_) impl_ = std::make_unique<Impl>();
  impl_->points.assign(points.begin(), points.end());
  impl_->rebuild();
}

std::size_t PointCloudIndex::size() const { return impl_ ? impl_->points.size() : 0; }

const std::vector<Eigen::Vector3f>& PointCloudIndex::points() const {
  static const std::vector<Eigen::Vector3f> kEmpty;
  return impl_ ? impl_->points : kEmpty;
}

bool PointCloudIndex::nearest(const Eigen::Vector3f& query, uint32_t& index,
                              float& dist_sq) const {
  std::size_t i = 0;
  float d = 0;
  if (knn(query, 1, {&i, 1}, {&d, 1}) != 1) return false;
  index = uint32_t(i);
  dist_sq = d;
  return true;
}

std::size_t PointCloudIndex::knn(const Eigen::Vector3f& query, std::size_t k,
                                 std::span<std::size_t> indices, std::span<float> dist_sq) const {
  k = std::min({k, indices.size(), dist_sq.size(), size()});
  if (k == 0 || !query.allFinite()) return 0;
  return impl_->tree->knnSearch(query.data(), k, indices.data(), dist_sq.data());
}

std::size_t PointCloudIndex::radius(const Eigen::Vector3f& query, float radius_m,
                                    std::vector<std::pair<std::size_t, float>>& out) const {
  out.clear();
  if (size() == 0 || !query.allFinite() || !(radius_m > 0)) return 0;
  nanoflann::SearchParams params;
  params.sorted = true;
  // L2_Simple works in squared distances.
  return impl_->tree->radiusSearch(query.data(), radius_m * radius_m, out, params);
}

}  // namespace seavio::icp
