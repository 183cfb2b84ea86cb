#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/matching/stereo_completion.hpp"
#include "tests/core/matching/sand_texture.hpp"

namespace seavio::matching {
namespace {

constexpr double kDisparityPx = 20.25;  // a flat floor facing the rig: one disparity everywhere

camera::RectifiedRig rig() {
  camera::RectifiedRig r;
  r.width = 320;
  r.height = 240;
  r.f_px = 300;
  r.cx = 160;
  r.cy = 120;
  r.baseline_m = 0.27;  // 300 * 0.27 / 20.25 = 4 m
  return r;
}

struct Pair {
  cv::Mat left, right;
};

/// The right image is the left moved by the disparity along the row (sub-pixel, cubic).
Pair floorPair(int seed) {
  const cv::Mat world = test::sandTexture(seed, cv::Size(320, 240), CV_32F);
  Pair p;
  world.convertTo(p.left, CV_8U);
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, -kDisparityPx, 0, 1, 0);
  cv::Mat r;
  cv::warpAffine(world, r, M, world.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  r.convertTo(p.right, CV_8U);
  return p;
}

StereoPoint matchedAt(const camera::RectifiedRig& r, int left_index, float u, float v, double disparity) {
  StereoPoint s;
  s.left_index = left_index;
  s.right_index = left_index;
  s.uv_left = {u, v};
  s.uv_right = {u - static_cast<float>(disparity), v};
  s.p_R0 = r.triangulate(s.uv_left.cast<double>(), disparity).cast<float>();
  return s;
}

/// Keypoints on a 10 px grid inside the right image's reach; every other one is already
/// matched (with the true disparity), the rest are left for completion.
struct Scene {
  std::vector<cv::KeyPoint> keypoints;
  std::vector<StereoPoint> matched;
};
Scene gridScene(const camera::RectifiedRig& r, double matched_disparity = kDisparityPx) {
  Scene s;
  for (int v = 40; v <= 200; v += 10)
    for (int u = 60; u <= 280; u += 10) {
      const int i = static_cast<int>(s.keypoints.size());
      s.keypoints.emplace_back(static_cast<float>(u) + 0.3f, static_cast<float>(v) + 0.6f, 12.f);
      const cv::Point2f pt = s.keypoints.back().pt;
      if (i % 2 == 0) s.matched.push_back(matchedAt(r, i, pt.x, pt.y, matched_disparity));
    }
  return s;
}

/// Completion on for any share of paired features (the grid pairs half of them).
StereoMatchParams enabled() {
  StereoMatchParams p;
  p.completion.enabled = true;
  p.completion.max_matched_share = 1.0;
  return p;
}

TEST(StereoCompletion, UnmatchedFloorFeaturesAreAlignedAtTheirNeighboursDisparity) {
  const camera::RectifiedRig r = rig();
  const Pair pair = floorPair(3);
  Scene s = gridScene(r);
  const std::size_t before = s.matched.size();
  const std::size_t unmatched = s.keypoints.size() - before;
  StereoCompletionWorkspace ws;
  const int added = completeStereo(s.keypoints, pair.left, pair.right, r, enabled(), ws, s.matched);
  ASSERT_EQ(static_cast<std::size_t>(added), s.matched.size() - before);
  // Nearly all of them (a flat patch of the noise texture may be refused), each where it is.
  EXPECT_GE(added, static_cast<int>(0.9 * static_cast<double>(unmatched)));
  for (std::size_t i = before; i < s.matched.size(); ++i) {
    const StereoPoint& p = s.matched[i];
    EXPECT_EQ(p.right_index, -1);
    EXPECT_EQ(p.left_index % 2, 1);  // only the unmatched keypoints
    EXPECT_NEAR(p.uv_left.x() - p.uv_right.x(), kDisparityPx, 0.1) << "keypoint " << p.left_index;
    EXPECT_NEAR(p.uv_right.y(), p.uv_left.y(), 0.1);
    EXPECT_NEAR(p.p_R0.z(), 4.0, 0.03);
  }
}

TEST(StereoCompletion, ReachesAStartTwoPixelsOffThePrediction) {
  // The neighbours say 18.25 px; the floor is at 20.25: the starts either side find it.
  const camera::RectifiedRig r = rig();
  const Pair pair = floorPair(5);
  Scene s = gridScene(r, kDisparityPx - 2.0);
  const std::size_t before = s.matched.size();
  StereoCompletionWorkspace ws;
  const int added = completeStereo(s.keypoints, pair.left, pair.right, r, enabled(), ws, s.matched);
  EXPECT_GE(added, static_cast<int>(0.8 * static_cast<double>(s.keypoints.size() - before)));
  for (std::size_t i = before; i < s.matched.size(); ++i)
    EXPECT_NEAR(s.matched[i].uv_left.x() - s.matched[i].uv_right.x(), kDisparityPx, 0.1);
}

TEST(StereoCompletion, ASnowParticleInTheLeftImageOnlyIsNotCompleted) {
  // A lit particle much nearer than the floor sits elsewhere in the right image: at the floor's
  // disparity its patch finds floor, which does not correlate.
  const camera::RectifiedRig r = rig();
  Pair pair = floorPair(7);
  Scene s = gridScene(r);
  const cv::Point2f particle(175.3f, 135.6f);  // between grid points
  cv::circle(pair.left, cv::Point(175, 136), 4, cv::Scalar(250), cv::FILLED, cv::LINE_AA);
  s.keypoints.emplace_back(particle, 8.f);
  const int particle_index = static_cast<int>(s.keypoints.size()) - 1;
  StereoCompletionWorkspace ws;
  completeStereo(s.keypoints, pair.left, pair.right, r, enabled(), ws, s.matched);
  for (const StereoPoint& p : s.matched) EXPECT_NE(p.left_index, particle_index);
}

TEST(StereoCompletion, NeighboursDisagreeingInDepthAreNoPrediction) {
  const camera::RectifiedRig r = rig();
  const Pair pair = floorPair(9);
  Scene s = gridScene(r);
  // Every other matched point a metre nearer: a depth edge everywhere, nothing is predicted.
  for (std::size_t i = 0; i < s.matched.size(); i += 2) {
    const StereoPoint& m = s.matched[i];
    s.matched[i] = matchedAt(r, m.left_index, m.uv_left.x(), m.uv_left.y(), r.disparityAt(3.0));
  }
  const std::size_t before = s.matched.size();
  StereoCompletionWorkspace ws;
  EXPECT_EQ(completeStereo(s.keypoints, pair.left, pair.right, r, enabled(), ws, s.matched), 0);
  EXPECT_EQ(s.matched.size(), before);
}

TEST(StereoCompletion, AFrameWhoseDescriptorsPairedHalfItsFeaturesIsLeftAlone) {
  // The grid scene pairs every other keypoint: a share of 0.5 (clear water's frames pair more).
  const camera::RectifiedRig r = rig();
  const Pair pair = floorPair(13);
  Scene s = gridScene(r);
  StereoMatchParams p = enabled();
  StereoCompletionWorkspace ws;
  p.completion.max_matched_share = 0.5;
  EXPECT_EQ(completeStereo(s.keypoints, pair.left, pair.right, r, p, ws, s.matched), 0);
  p.completion.max_matched_share = 0.55;
  EXPECT_GT(completeStereo(s.keypoints, pair.left, pair.right, r, p, ws, s.matched), 0);
}

TEST(StereoCompletion, DisabledOrWithoutImagesAddsNothing) {
  const camera::RectifiedRig r = rig();
  const Pair pair = floorPair(11);
  Scene s = gridScene(r);
  const std::size_t before = s.matched.size();
  StereoCompletionWorkspace ws;
  EXPECT_EQ(completeStereo(s.keypoints, pair.left, pair.right, r, StereoMatchParams{}, ws, s.matched), 0);
  EXPECT_EQ(completeStereo(s.keypoints, cv::Mat(), pair.right, r, enabled(), ws, s.matched), 0);
  EXPECT_EQ(s.matched.size(), before);
}

}  // namespace
}  // namespace seavio::matching
