#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "core/map/frame_map.hpp"

namespace seavio::map {
namespace {

MapFrame frameAt(uint64_t id, double x, double y, int n_points = 10) {
  MapFrame f;
  f.id = id;
  f.T_W_R0.translation() = Eigen::Vector3d(x, y, 4.0);
  for (int i = 0; i < n_points; ++i) f.points_R0.emplace_back(0.01f * static_cast<float>(i), 0.f, 4.f);
  return f;
}

/// A lawnmower's two legs: a frame every 0.5 m for 50 m along x, at y = 0 and y = `leg2_y_m`.
void insertTwoLegs(FrameMap& map, double leg2_y_m) {
  uint64_t id = 0;
  for (int i = 0; i < 100; ++i) map.insert(frameAt(id++, 0.5 * i, 0.0));
  for (int i = 0; i < 100; ++i) map.insert(frameAt(id++, 0.5 * i, leg2_y_m));
}

TEST(FrameMap, SelectsFramesWithinTheRadiusNearestFirst) {
  // GIVEN a lawnmower of frames every 0.5 m on two legs 3 m apart
  FrameMapParams p;
  p.selection_radius_m = 2.0;
  p.max_selected_frames = 100;
  FrameMap map(p);
  insertTwoLegs(map, 3.0);
  // WHEN selecting near (10, 1.5)
  const auto sel = map.selectNear(Eigen::Vector3d(10.0, 1.5, 4.0));
  // THEN exactly the frames within 2 m are returned, nearest first
  int expected = 0;
  for (int leg = 0; leg < 2; ++leg)
    for (int i = 0; i < 100; ++i)
      expected += std::hypot(0.5 * i - 10.0, (leg ? 3.0 : 0.0) - 1.5) <= 2.0;
  ASSERT_EQ(static_cast<int>(sel.size()), expected);
  for (std::size_t i = 1; i < sel.size(); ++i) {
    const double a = (sel[i - 1]->T_W_R0.translation() - Eigen::Vector3d(10, 1.5, 4)).norm();
    const double b = (sel[i]->T_W_R0.translation() - Eigen::Vector3d(10, 1.5, 4)).norm();
    EXPECT_LE(a, b + 1e-12);
  }
  // Both legs contribute: the revisit is what bounds the drift.
  bool leg0 = false, leg1 = false;
  for (const auto* f : sel) (f->T_W_R0.translation().y() < 1 ? leg0 : leg1) = true;
  EXPECT_TRUE(leg0 && leg1);
}

TEST(FrameMap, SelectsWithinAnyRadiusUncappedNearestFirst) {
  // GIVEN two 50 m lanes 12 m apart, a frame every 0.5 m, cells of 2.5 m, a cap of 12
  FrameMapParams p;
  p.selection_radius_m = 2.5;
  p.max_selected_frames = 12;
  FrameMap map(p);
  insertTwoLegs(map, 12.0);
  const Eigen::Vector3d q(20.0, 7.0, 4.0);
  // WHEN the re-observation search asks for a radius of several cells (grid walk), and for
  // one wider than the mission (every frame tested)
  for (const double radius : {8.0, 200.0}) {
    const auto sel = map.selectWithin(q, radius);
    // THEN every frame within the radius comes back, beyond the selection cap, nearest first
    int expected = 0;
    for (int leg = 0; leg < 2; ++leg)
      for (int i = 0; i < 100; ++i) expected += std::hypot(0.5 * i - 20.0, (leg ? 12.0 : 0.0) - 7.0) <= radius;
    ASSERT_EQ(static_cast<int>(sel.size()), expected) << "radius " << radius;
    EXPECT_GT(sel.size(), 12u);
    for (std::size_t i = 1; i < sel.size(); ++i)
      EXPECT_LE((sel[i - 1]->T_W_R0.translation() - q).norm(), (sel[i]->T_W_R0.translation() - q).norm() + 1e-12);
    // the far lane (5 m away) is found, which the 2.5 m selection cannot reach
    EXPECT_GT(sel.front()->T_W_R0.translation().y(), 6.0);
  }
  EXPECT_TRUE(map.selectNear(q).empty());
  EXPECT_TRUE(map.selectWithin(q, std::numeric_limits<double>::quiet_NaN()).empty());
}

TEST(FrameMap, CapsTheSelectionAndTheStoredPoints) {
  FrameMapParams p;
  p.max_selected_frames = 3;
  p.max_points_per_frame = 5;
  FrameMap map(p);
  for (int i = 0; i < 10; ++i) map.insert(frameAt(static_cast<uint64_t>(i), 0.1 * i, 0.0, 50));
  EXPECT_EQ(map.selectNear(Eigen::Vector3d(0, 0, 4)).size(), 3u);
  EXPECT_EQ(map.pointCount(), 50u);
  EXPECT_GT(map.memoryBytes(), 50 * sizeof(Eigen::Vector3f));
}

TEST(FrameMap, ModelCloudIsVoxelDownsampledInTheWorldFrame) {
  FrameMapParams p;
  p.voxel_size_m = 0.05;
  FrameMap map(p);
  map.insert(frameAt(0, 0.0, 0.0));
  map.insert(frameAt(1, 0.0, 0.0));  // the same points again
  const auto model = map.buildModel(map.selectNear(Eigen::Vector3d(0, 0, 4)));
  // 10 points 1 cm apart fall into 2 voxels of 5 cm; duplicates vanish.
  EXPECT_LE(model.points_W.size(), 3u);
  EXPECT_GE(model.points_W.size(), 2u);
  EXPECT_NEAR(model.points_W.front().z(), 8.0f, 1e-5);  // 4 m camera height + 4 m depth
}

TEST(FrameMap, KeyframePolicyByDistanceAndAngle) {
  FrameMapParams p;
  p.keyframe_distance_m = 0.5;
  p.keyframe_angle_rad = 0.2;
  p.overlap_radius_m = 0.0;  // the travel/rotation rule alone
  FrameMap map(p);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  EXPECT_TRUE(map.wantsKeyframe(T));
  map.insert(MapFrame{0, 0, T, {}});
  T.translation().x() = 0.3;
  EXPECT_FALSE(map.wantsKeyframe(T));
  T.translation().x() = 0.6;
  EXPECT_TRUE(map.wantsKeyframe(T));
  T.translation().x() = 0.0;
  T.linear() = Eigen::AngleAxisd(0.25, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(map.wantsKeyframe(T));
}

}  // namespace
}  // namespace seavio::map
