// The map's memory follows the area surveyed, not the time spent over it:
// keyframe policy on travel AND overlap, packed points, bounded cost per keyframe.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/map/frame_map.hpp"

namespace seavio::map {
namespace {

/// A nadir camera (optical axis +z of R0 pointing down = -z of W) at (x, y, -4) with heading `yaw`.
Eigen::Isometry3d nadirPose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, -4.0);
  return T;
}

std::vector<Eigen::Vector3f> floorPoints(std::mt19937& rng, int n) {
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < n; ++i) pts.emplace_back(u(rng), 0.75f * u(rng), 4.0f + 0.1f * u(rng));
  return pts;
}

/// What the odometry does each frame: ask, then insert.
void offer(FrameMap& map, uint64_t& id, const Eigen::Isometry3d& T, std::mt19937& rng, int n_points = 500) {
  if (map.wantsKeyframe(T)) map.insert(MapFrame{id, static_cast<int64_t>(id) * 100'000'000, T, floorPoints(rng, n_points)});
  ++id;
}

/// One pass of a small lawnmower box: `legs` legs of `length` m, `spacing` m apart, `step` m
/// per frame starting `phase` m into each leg.
std::vector<Eigen::Isometry3d> lawnmower(int legs, double length, double spacing, double step, double y_offset,
                                         double phase = 0.0) {
  std::vector<Eigen::Isometry3d> poses;
  for (int leg = 0; leg < legs; ++leg) {
    const bool back = leg % 2 == 1;
    for (double s = phase; s <= length; s += step)
      poses.push_back(nadirPose(back ? length - s : s, leg * spacing + y_offset, back ? M_PI : 0.0));
  }
  return poses;
}

TEST(FrameMapMemory, HoveringOverTheSameGroundAddsNoKeyframes) {
  // GIVEN a vehicle holding station for 10,000 frames: position jitter of a few cm and a
  // slow full turn about the vertical (the old travel-or-rotation rule took a keyframe every
  // 0.15 rad, i.e. 42 per turn, forever)
  std::mt19937 rng(7);
  std::normal_distribution<double> jitter(0.0, 0.05);
  FrameMap map;
  uint64_t id = 0;
  for (int i = 0; i < 10'000; ++i) offer(map, id, nadirPose(jitter(rng), jitter(rng), 0.01 * i), rng);
  // THEN the first keyframe covers the whole stay
  EXPECT_EQ(map.size(), 1u);
  EXPECT_EQ(map.pointCount(), 500u);
}

TEST(FrameMapMemory, RepeatedPassesOverMappedGroundAddNoKeyframes) {
  // GIVEN a 30 m x 12 m lawnmower box flown 10 times at 1.5 m per frame (the paper's 1 Hz),
  // each pass offset sideways by up to 0.4 m and along the legs by up to 1.5 m (frames fall
  // between the old keyframes), in alternating direction
  std::mt19937 rng(3);
  FrameMap map;
  uint64_t id = 0;
  std::size_t after_first = 0, bytes_after_first = 0;
  for (int pass = 0; pass < 10; ++pass) {
    auto poses = lawnmower(4, 30.0, 4.0, 1.5, 0.4 * std::sin(pass), std::fmod(0.37 * pass, 1.5));
    if (pass % 2 == 1) std::reverse(poses.begin(), poses.end());
    for (const auto& T : poses) offer(map, id, T, rng);
    if (pass == 0) after_first = map.size(), bytes_after_first = map.memoryBytes();
  }
  // THEN the first pass made the map; nine more passes (9x the frames) added nothing
  EXPECT_GE(after_first, 4u * 20u);
  EXPECT_EQ(map.size(), after_first);
  EXPECT_EQ(map.memoryBytes(), bytes_after_first);
}

TEST(FrameMapMemory, NewGroundStillGetsKeyframes) {
  // GIVEN the same box, then a leg beside it (10 m away: outside the overlap radius)
  std::mt19937 rng(4);
  FrameMap map;
  uint64_t id = 0;
  for (const auto& T : lawnmower(2, 30.0, 4.0, 0.1, 0.0)) offer(map, id, T, rng);
  const std::size_t before = map.size();
  for (const auto& T : lawnmower(1, 30.0, 4.0, 0.1, 14.0)) offer(map, id, T, rng);
  // THEN the new leg is mapped at the overlap spacing (1 m): 30 m -> ~30 keyframes
  EXPECT_GE(map.size() - before, 25u);
  EXPECT_LE(map.size() - before, 35u);
}

TEST(FrameMapMemory, CoverageIgnoresHeadingButNotTheViewAxis) {
  FrameMapParams p;
  p.overlap_radius_m = 1.0;
  FrameMap map(p);
  map.insert(MapFrame{0, 0, nadirPose(0, 0, 0), {}});
  // Facing the other way over the same floor (a return leg): covered.
  EXPECT_NE(map.coveringKeyframe(nadirPose(0.6, 0.3, M_PI)), nullptr);
  EXPECT_FALSE(map.wantsKeyframe(nadirPose(0.6, 0.3, M_PI)));
  // Too far: not covered.
  EXPECT_EQ(map.coveringKeyframe(nadirPose(1.2, 0, 0)), nullptr);
  EXPECT_TRUE(map.wantsKeyframe(nadirPose(1.2, 0, 0)));
  // Same place, camera tilted by 0.3 rad (> keyframe_angle_rad): a different view.
  Eigen::Isometry3d tilted = nadirPose(0, 0, 0);
  tilted.linear() = tilted.linear() * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_EQ(map.coveringKeyframe(tilted), nullptr);
  EXPECT_TRUE(map.wantsKeyframe(tilted));
  // Disabled: only travel and rotation count.
  p.overlap_radius_m = 0.0;
  FrameMap plain(p);
  plain.insert(MapFrame{0, 0, nadirPose(0, 0, 0), {}});
  EXPECT_EQ(plain.coveringKeyframe(nadirPose(0.6, 0, 0)), nullptr);
  EXPECT_TRUE(plain.wantsKeyframe(nadirPose(0.6, 0, 0)));
}

TEST(FrameMapMemory, MemoryPerKeyframeIsBoundedWhateverTheInput) {
  // GIVEN keyframes with 5,000 points each (far above the 600 cap)
  std::mt19937 rng(5);
  FrameMapParams p;
  FrameMap map(p);
  for (int i = 0; i < 300; ++i) map.insert(MapFrame{static_cast<uint64_t>(i), i, nadirPose(2.0 * i, 0, 0), floorPoints(rng, 5000)});
  // THEN each holds the cap, and the bytes per keyframe stay below the bound, which itself is
  // below what the float form of the points alone would take
  EXPECT_EQ(map.pointCount(), 300u * 600u);
  EXPECT_LE(map.memoryBytes(), map.size() * map.maxBytesPerKeyframe());
  EXPECT_LT(map.maxBytesPerKeyframe(), 600u * sizeof(Eigen::Vector3f));
  EXPECT_GE(map.memoryBytes(), map.pointCount() * sizeof(PackedPoint));
  for (const MapFrame* f : map.selectNear(Eigen::Vector3d(100, 0, -4))) {
    EXPECT_TRUE(f->points_R0.empty());  // the float input was released
    EXPECT_EQ(f->packed_R0.size(), 600u);
    EXPECT_EQ(f->packed_R0.capacity(), 600u);
  }
}

TEST(FrameMapMemory, KeepsTheStrongestPointsPackedToTheMillimetre) {
  // GIVEN points in the front end's order (strongest first), one out of int16 range, one NaN
  FrameMapParams p;
  p.max_points_per_frame = 4;
  FrameMap map(p);
  std::vector<Eigen::Vector3f> pts = {{0.1234f, -0.5f, 4.0004f}, {40.0f, 0.f, 4.f}, {-1.0f, 2.0f, 3.9996f},
                                      {std::nanf(""), 0.f, 4.f},  {0.5f, 0.5f, 5.0f},  {0.7f, 0.1f, 4.2f},
                                      {0.9f, 0.9f, 4.9f}};
  map.insert(MapFrame{0, 0, Eigen::Isometry3d::Identity(), pts});
  const auto sel = map.selectNear(Eigen::Vector3d::Zero());
  ASSERT_EQ(sel.size(), 1u);
  const std::vector<Eigen::Vector3f> got = sel[0]->points();
  // THEN the first four valid points are kept, each within 0.5 mm
  const std::vector<Eigen::Vector3f> want = {pts[0], pts[2], pts[4], pts[5]};
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_LE((got[i] - want[i]).cwiseAbs().maxCoeff(), 0.00051f) << i;
  PackedPoint q;
  EXPECT_FALSE(packPoint(Eigen::Vector3f(0, 0, 33.0f), q));
  EXPECT_TRUE(packPoint(Eigen::Vector3f(0, 0, -32.7f), q));
  EXPECT_EQ(q.z_mm, -32700);
}

TEST(FrameMapMemory, SelectionAndModelMatchABruteForceScan) {
  // GIVEN 2,000 keyframes scattered over 60 m x 60 m at two depths, overlap rule off so all are kept
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-30.0, 30.0);
  FrameMapParams p;
  p.selection_radius_m = 2.5;
  p.max_selected_frames = 1000;
  p.overlap_radius_m = 0.0;
  FrameMap map(p);
  std::vector<std::pair<Eigen::Isometry3d, std::vector<Eigen::Vector3f>>> truth;
  for (int i = 0; i < 2000; ++i) {
    Eigen::Isometry3d T = nadirPose(u(rng), u(rng), u(rng));
    T.translation().z() = i % 2 ? -4.0 : -6.5;
    auto pts = floorPoints(rng, 20);
    truth.emplace_back(T, pts);
    map.insert(MapFrame{static_cast<uint64_t>(i), i, T, pts});
  }
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d c(u(rng), u(rng), q % 3 ? -4.0 : -5.0);
    std::vector<uint64_t> want;
    for (std::size_t i = 0; i < truth.size(); ++i)
      if ((truth[i].first.translation() - c).norm() <= 2.5) want.push_back(i);
    const auto sel = map.selectNear(c);
    std::vector<uint64_t> got;
    for (const auto* f : sel) got.push_back(f->id);
    std::sort(got.begin(), got.end());
    ASSERT_EQ(got, want) << "query " << q;
    // The model built from packed points lands within a millimetre of the float points.
    if (sel.empty()) continue;
    const ModelCloud model = map.buildModel({sel.front()});
    const auto& [T, pts] = truth[sel.front()->id];
    ASSERT_EQ(model.points_W.size(), pts.size());  // 20 points, far apart in 1 cm voxels
    for (std::size_t k = 0; k < pts.size(); ++k)
      EXPECT_LE((model.points_W[k] - (T.cast<float>() * pts[k])).norm(), 1e-3f);
  }
}

}  // namespace
}  // namespace seavio::map
