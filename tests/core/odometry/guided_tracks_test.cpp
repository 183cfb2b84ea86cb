// trackUnmatched: reference stereo points without a descriptor match are found again by patch
// alignment where the motion puts them, in a rendered textured floor seen by the rectified
// pair before and after a move; points a bright particle hides are not.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "core/odometry/guided_tracks.hpp"
#include "downward_rig.hpp"

namespace seavio::odometry {
namespace {

constexpr double kDepthM = 4.0;         // fronto-parallel floor in front of both poses
constexpr double kTexelM = 0.003;       // texture resolution on the floor
constexpr double kTextureOriginM = -3.5;

/// Sand-like floor texture: blurred white noise (~1.6 px correlation at 4 m). Not the feature
/// tests' makeTexture: its smooth cells and ellipses leave patches too flat to pin to 0.1 px.
cv::Mat floorTexture() {
  cv::Mat f(2400, 2400, CV_32F);
  cv::RNG rng(7);
  rng.fill(f, cv::RNG::NORMAL, 0, 1);
  cv::GaussianBlur(f, f, cv::Size(), 4.0);
  cv::Scalar mean, sd;
  cv::meanStdDev(f, mean, sd);
  return (f - mean[0]) * (40.0 / sd[0]) + 128.0;
}

/// Camera `cam` (0 left, 1 right) of the rig at T_ref_cam (a turn about the optical axis and
/// a move parallel to the floor, in the reference R0) looking at the floor.
cv::Mat render(const cv::Mat& texture, const camera::RectifiedRig& r, const Eigen::Isometry3d& T_ref_cam, int cam) {
  cv::Mat map_x(r.height, r.width, CV_32F), map_y(r.height, r.width, CV_32F);
  for (int v = 0; v < r.height; ++v)
    for (int u = 0; u < r.width; ++u) {
      Eigen::Vector3d p((u - r.cx) * kDepthM / r.f_px, (v - r.cy) * kDepthM / r.f_px, kDepthM);
      if (cam == 1) p.x() += r.baseline_m;
      const Eigen::Vector3d P = T_ref_cam * p;
      map_x.at<float>(v, u) = static_cast<float>((P.x() - kTextureOriginM) / kTexelM);
      map_y.at<float>(v, u) = static_cast<float>((P.y() - kTextureOriginM) / kTexelM);
    }
  cv::Mat img, out;
  cv::remap(texture, img, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT);
  img.convertTo(out, CV_8U);
  return out;
}

Eigen::Isometry3d motion(double yaw_rad, double x_m, double y_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, y_m, 0);
  return T;
}

TEST(GuidedTracks, FindsTheUnmatchedPointsWhereTheMotionPutsThemAndNotUnderAParticle) {
  const camera::RectifiedRig r = test::rectifiedDownwardRig();
  const cv::Mat texture = floorTexture();
  const Eigen::Isometry3d T_ref_curr = motion(0.05, 0.30, 0.10);
  const cv::Mat ref_left = render(texture, r, Eigen::Isometry3d::Identity(), 0);
  const cv::Mat ref_right = render(texture, r, Eigen::Isometry3d::Identity(), 1);
  cv::Mat curr_left = render(texture, r, T_ref_curr, 0);
  const cv::Mat curr_right = render(texture, r, T_ref_curr, 1);

  // 300 reference points on a grid; the first 100 have descriptor matches already.
  matching::StereoFeatures ref;
  std::vector<matching::TemporalMatch> matched;
  std::vector<Eigen::Vector3d> truth_R0;
  for (int gy = 0; gy < 15; ++gy)
    for (int gx = 0; gx < 20; ++gx) {
      const Eigen::Vector2d uv(40 + 28.0 * gx + 0.37 * gy, 40 + 28.0 * gy + 0.21 * gx);
      const Eigen::Vector3d p = r.triangulate(uv, r.disparityAt(kDepthM));
      matching::StereoPoint sp;
      sp.uv_left = uv.cast<float>();
      // SURF's right position is ~0.3 px off: the alignment in the right image corrects it.
      sp.uv_right = r.project(p, 1).cast<float>() + Eigen::Vector2f(0.3f, 0.f);
      sp.p_R0 = p.cast<float>();
      if (ref.points.size() < 100) matched.push_back({static_cast<int>(ref.points.size()), 0, 0.f});
      ref.points.push_back(sp);
      truth_R0.push_back(p);
    }
  // A bright particle over 20 of the unmatched points in the current left image.
  std::vector<int> hidden;
  for (int i = 150; i < 170; ++i) {
    const Eigen::Vector2d uv = r.project(T_ref_curr.inverse() * truth_R0[static_cast<std::size_t>(i)], 0);
    cv::circle(curr_left, cv::Point(int(std::lround(uv.x())), int(std::lround(uv.y()))), 9, cv::Scalar(250), -1,
               cv::LINE_AA);
    hidden.push_back(i);
  }
  // RANSAC's motion is not exact: 4 mm and 0.3 mrad off (about half a pixel).
  const Eigen::Isometry3d T_estimate = T_ref_curr * motion(3e-4, 0.004, -0.002);

  std::vector<uint8_t> used;
  std::vector<geometry::QuadMatch> quads(matched.size());  // the descriptor matches' quads come first
  const int added = trackUnmatched(ref, ref_left, ref_right, curr_left, curr_right, r, T_estimate, matched,
                                   matching::PatchAlignParams{}, GuidedTrackParams{}, nullptr, used, quads);
  ASSERT_EQ(static_cast<std::size_t>(added) + matched.size(), quads.size());

  // With a keyframe's cache the same quads come out, bit for bit; and the second frame tracked
  // against that keyframe takes the reference-right positions from the cache: with the
  // reference right image blanked, uncached nothing aligns, cached the same quads return.
  ReferenceAlignments cache;
  cache.reset(1, ref.points.size());
  const auto cachedRun = [&](const cv::Mat& right) {
    std::vector<geometry::QuadMatch> out(matched.size());
    trackUnmatched(ref, ref_left, right, curr_left, curr_right, r, T_estimate, matched, matching::PatchAlignParams{},
                   GuidedTrackParams{}, &cache, used, out);
    return out;
  };
  const auto sameQuads = [&](const std::vector<geometry::QuadMatch>& a) {
    if (a.size() != quads.size()) return false;
    for (std::size_t k = 0; k < a.size(); ++k)
      if (a[k].left_prev != quads[k].left_prev || a[k].right_prev != quads[k].right_prev ||
          a[k].left_curr != quads[k].left_curr || a[k].right_curr != quads[k].right_curr)
        return false;
    return true;
  };
  EXPECT_TRUE(sameQuads(cachedRun(ref_right)));
  const cv::Mat blank(ref_right.size(), ref_right.type(), cv::Scalar(128));
  EXPECT_TRUE(sameQuads(cachedRun(blank)));
  std::vector<geometry::QuadMatch> uncached(matched.size());
  EXPECT_EQ(trackUnmatched(ref, ref_left, blank, curr_left, curr_right, r, T_estimate, matched,
                           matching::PatchAlignParams{}, GuidedTrackParams{}, nullptr, used, uncached),
            0);
  // A new keyframe starts over: its blank right image aligns nothing.
  cache.reset(2, ref.points.size());
  EXPECT_EQ(cachedRun(blank).size(), matched.size());

  // Which unmatched points are in view in both current images (with the patch's margin).
  int in_view = 0;
  for (std::size_t i = matched.size(); i < ref.points.size(); ++i) {
    const Eigen::Vector3d p = T_ref_curr.inverse() * truth_R0[i];
    const Eigen::Vector2d l = r.project(p, 0), rr = r.project(p, 1);
    if (l.x() > 12 && l.y() > 12 && l.x() < 628 && l.y() < 468 && rr.x() > 12) ++in_view;
  }
  ASSERT_GT(in_view, 120);
  EXPECT_GE(added, static_cast<int>(0.85 * (in_view - static_cast<int>(hidden.size()))));
  EXPECT_LE(added, in_view - static_cast<int>(hidden.size()) / 2);

  // Every quad sits on the truth, and none belongs to a matched or a hidden point.
  for (std::size_t k = matched.size(); k < quads.size(); ++k) {
    const geometry::QuadMatch& q = quads[k];
    std::size_t i = 0;
    while (i < ref.points.size() && (ref.points[i].uv_left - q.left_prev).norm() > 1e-4f) ++i;
    ASSERT_LT(i, ref.points.size());
    EXPECT_GE(i, matched.size());
    EXPECT_TRUE(std::find(hidden.begin(), hidden.end(), static_cast<int>(i)) == hidden.end()) << i;
    const Eigen::Vector3d p = T_ref_curr.inverse() * truth_R0[i];
    EXPECT_LT((q.right_prev.cast<double>() - r.project(truth_R0[i], 1)).norm(), 0.1) << i;
    EXPECT_LT((q.left_curr.cast<double>() - r.project(p, 0)).norm(), 0.1) << i;
    EXPECT_LT((q.right_curr.cast<double>() - r.project(p, 1)).norm(), 0.1) << i;
  }
}

TEST(GuidedTracks, OffAddsNothing) {
  const camera::RectifiedRig r = test::rectifiedDownwardRig();
  const cv::Mat texture = floorTexture();
  const cv::Mat left = render(texture, r, Eigen::Isometry3d::Identity(), 0);
  const cv::Mat right = render(texture, r, Eigen::Isometry3d::Identity(), 1);
  matching::StereoFeatures ref;
  matching::StereoPoint sp;
  sp.p_R0 = Eigen::Vector3f(0.2f, -0.1f, static_cast<float>(kDepthM));
  sp.uv_left = r.project(sp.p_R0.cast<double>(), 0).cast<float>();
  sp.uv_right = r.project(sp.p_R0.cast<double>(), 1).cast<float>();
  ref.points.push_back(sp);
  std::vector<uint8_t> used;
  std::vector<geometry::QuadMatch> quads;
  GuidedTrackParams off;
  off.enabled = false;
  const Eigen::Isometry3d still = Eigen::Isometry3d::Identity();
  EXPECT_EQ(trackUnmatched(ref, left, right, left, right, r, still, {}, {}, off, nullptr, used, quads), 0);
  EXPECT_TRUE(quads.empty());
  EXPECT_EQ(trackUnmatched(ref, left, right, left, right, r, still, {}, {}, {}, nullptr, used, quads), 1);
  ASSERT_EQ(quads.size(), 1u);
  // Matched already: not looked for again.
  const std::vector<matching::TemporalMatch> matched{{0, 0, 0.f}};
  EXPECT_EQ(trackUnmatched(ref, left, right, left, right, r, still, matched, {}, {}, nullptr, used, quads), 0);
}

}  // namespace
}  // namespace seavio::odometry
