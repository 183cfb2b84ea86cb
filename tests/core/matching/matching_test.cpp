#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/se3.hpp"
#include "core/matching/stereo_matcher.hpp"
#include "core/matching/temporal_matcher.hpp"

namespace seavio::matching {
namespace {

camera::RectifiedRig makeRig() {
  camera::RectifiedRig rig;
  rig.width = 640;
  rig.height = 480;
  rig.f_px = 554.0;
  rig.cx = 320;
  rig.cy = 240;
  rig.baseline_m = 0.32;
  return rig;
}

cv::Mat randomDescriptors(int n, std::mt19937& rng) {
  cv::Mat d(n, 64, CV_32F);
  std::normal_distribution<float> g;
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 64; ++k) d.at<float>(i, k) = g(rng);
    cv::normalize(d.row(i), d.row(i));
  }
  return d;
}

cv::Mat perturb(const cv::Mat& d, float sigma, std::mt19937& rng) {
  cv::Mat out = d.clone();
  std::normal_distribution<float> g(0.f, sigma);
  for (int i = 0; i < out.rows; ++i) {
    for (int k = 0; k < out.cols; ++k) out.at<float>(i, k) += g(rng);
    cv::normalize(out.row(i), out.row(i));
  }
  return out;
}

// A floor 3-5 m below the camera, seen by both rectified cameras.
std::vector<Eigen::Vector3d> floorPoints(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> ux(-1.8, 1.8), uy(-1.4, 1.4), uz(3.0, 5.0);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < n; ++i) pts.emplace_back(ux(rng), uy(rng), uz(rng));
  return pts;
}

TEST(StereoMatcher, MatchesAlongRowsAndTriangulates) {
  // GIVEN 300 points projected into a rectified pair, descriptors with noise, 100 distractors
  std::mt19937 rng(3);
  const auto rig = makeRig();
  const auto pts = floorPoints(300, rng);
  std::vector<cv::KeyPoint> left, right;
  for (const auto& p : pts) {
    const auto l = rig.project(p, 0), r = rig.project(p, 1);
    left.emplace_back(cv::Point2f(float(l.x()), float(l.y())), 10.f);
    right.emplace_back(cv::Point2f(float(r.x()), float(r.y())), 10.f);
  }
  const cv::Mat dl = randomDescriptors(300, rng);
  cv::Mat dr = perturb(dl, 0.02f, rng);
  std::uniform_real_distribution<float> ux(0, 640), uy(0, 480);
  for (int i = 0; i < 100; ++i) right.emplace_back(cv::Point2f(ux(rng), uy(rng)), 10.f);
  cv::vconcat(dr, randomDescriptors(100, rng), dr);
  // WHEN matched
  const auto matches = matchStereo(left, dl, right, dr, rig, StereoMatchParams{});
  // THEN nearly all true pairs are found, no wrong pair, and 3D points are exact
  EXPECT_GT(matches.size(), 285u);
  for (const auto& m : matches) {
    ASSERT_EQ(m.left_index, m.right_index);
    EXPECT_LT((m.p_R0.cast<double>() - pts[static_cast<std::size_t>(m.left_index)]).norm(), 1e-3);
  }
}

TEST(StereoMatcher, RespectsTheDisparityWindow) {
  std::mt19937 rng(4);
  const auto rig = makeRig();
  // A point at 20 m is outside a 1.5-12 m depth band, inside the rig's own range (the default).
  const Eigen::Vector3d p(0.1, 0.2, 20.0);
  const auto l = rig.project(p, 0), r = rig.project(p, 1);
  std::vector<cv::KeyPoint> left{cv::KeyPoint(float(l.x()), float(l.y()), 10.f)};
  std::vector<cv::KeyPoint> right{cv::KeyPoint(float(r.x()), float(r.y()), 10.f)};
  const cv::Mat d = randomDescriptors(1, rng);
  StereoMatchParams band;
  band.min_range_m = 1.5;
  band.max_range_m = 12;
  EXPECT_TRUE(matchStereo(left, d, right, d, rig, band).empty());
  band.max_range_m = 30;
  EXPECT_EQ(matchStereo(left, d, right, d, rig, band).size(), 1u);
  EXPECT_EQ(matchStereo(left, d, right, d, rig, StereoMatchParams{}).size(), 1u);
}

struct TwoFrames {
  StereoFeatures prev, curr;
  std::vector<int> truth;  // prev index -> curr index
};

// Previous and current frames of the same floor after motion T_prev_curr; the current frame's
// descriptors are shuffled copies, plus a repeated-texture twin of each point far away.
TwoFrames makeFrames(const Eigen::Isometry3d& T_prev_curr, std::mt19937& rng) {
  const auto rig = makeRig();
  const auto pts = floorPoints(250, rng);
  TwoFrames f;
  const cv::Mat d = randomDescriptors(250, rng);
  for (int i = 0; i < 250; ++i) {
    StereoPoint sp;
    sp.p_R0 = pts[i].cast<float>();
    sp.uv_left = rig.project(pts[i], 0).cast<float>();
    sp.uv_right = rig.project(pts[i], 1).cast<float>();
    f.prev.points.push_back(sp);
  }
  f.prev.descriptors = d;
  std::vector<int> order(250);
  for (int i = 0; i < 250; ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  f.truth.assign(250, -1);
  std::vector<cv::Mat> rows;
  const cv::Mat noisy = perturb(d, 0.02f, rng);
  for (int j = 0; j < 250; ++j) {
    const int i = order[j];
    const Eigen::Vector3d pc = T_prev_curr.inverse() * pts[i];
    StereoPoint sp;
    sp.p_R0 = pc.cast<float>();
    sp.uv_left = rig.project(pc, 0).cast<float>();
    sp.uv_right = rig.project(pc, 1).cast<float>();
    f.curr.points.push_back(sp);
    rows.push_back(noisy.row(i));
    f.truth[i] = j;
  }
  // Repeated texture: an identical-looking twin of every 3rd point, 150 px away.
  for (int j = 0; j < 250; j += 3) {
    StereoPoint twin = f.curr.points[j];
    twin.uv_left.x() = std::fmod(twin.uv_left.x() + 150.f, 640.f);
    twin.uv_right.x() = twin.uv_left.x() - (f.curr.points[j].uv_left.x() - f.curr.points[j].uv_right.x());
    f.curr.points.push_back(twin);
    rows.push_back(perturb(rows[static_cast<std::size_t>(j)], 0.005f, rng));
  }
  cv::vconcat(rows, f.curr.descriptors);
  return f;
}

TEST(TemporalMatcher, PredictionPrunesRepeatedTexture) {
  // GIVEN a 0.3 m forward motion with a 2 degree yaw and repeated texture in the current frame
  std::mt19937 rng(5);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = se3::expSO3(Eigen::Vector3d(0, 0, 0.035));
  T.translation() = Eigen::Vector3d(0.0, 0.3, 0.02);
  const TwoFrames f = makeFrames(T, rng);
  const auto rig = makeRig();
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
  cov.diagonal() << 1e-5, 1e-5, 1e-5, 1e-4, 1e-4, 1e-4;
  // WHEN matched with and without the IMU prediction
  TemporalMatchParams pruned;
  TemporalMatchParams unpruned;
  unpruned.use_prediction = false;
  const auto with = matchTemporal(f.prev, f.curr, rig, T, cov, pruned);
  const auto without = matchTemporal(f.prev, f.curr, rig, T, cov, unpruned);
  auto correct = [&](const std::vector<TemporalMatch>& ms) {
    int c = 0;
    for (const auto& m : ms) c += f.truth[static_cast<std::size_t>(m.prev)] == m.curr;
    return c;
  };
  // THEN pruning finds (nearly) every point and never a twin; without it the twins make the
  // ratio test reject a third of the points
  EXPECT_EQ(correct(with), static_cast<int>(with.size()));
  EXPECT_GT(correct(with), 240);
  EXPECT_LT(correct(without), 200);
}

TEST(TemporalMatcher, WindowGrowsWithUncertainty) {
  const auto rig = makeRig();
  TemporalMatchParams p;
  Eigen::Matrix<double, 6, 6> small = Eigen::Matrix<double, 6, 6>::Identity() * 1e-8;
  Eigen::Matrix<double, 6, 6> large = Eigen::Matrix<double, 6, 6>::Identity() * 1e-3;
  const double ws = predictionWindowPx(rig, 4.0, small, p);
  const double wl = predictionWindowPx(rig, 4.0, large, p);
  EXPECT_NEAR(ws, p.min_window_px, 1.0);
  EXPECT_GT(wl, 3 * ws);
  // No cap but the image: a covariance wider than the image searches all of it.
  Eigen::Matrix<double, 6, 6> huge = Eigen::Matrix<double, 6, 6>::Identity() * 1.0;
  EXPECT_NEAR(predictionWindowPx(rig, 4.0, huge, p), std::hypot(rig.width, rig.height), 1e-9);
}

// Reuse: the workspace versions reuse their buffers across frames; a reused (dirty)
// workspace and output must give exactly what fresh ones give, whatever sizes came before.
TEST(MatchingWorkspace, ReusedWorkspaceGivesTheSameMatchesAsAFreshOne) {
  const auto rig = makeRig();
  StereoMatchWorkspace stereo_ws;
  std::vector<StereoPoint> stereo_out;
  TemporalMatchWorkspace temporal_ws;
  std::vector<TemporalMatch> temporal_out;
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
  cov.diagonal() << 1e-5, 1e-5, 1e-5, 1e-4, 1e-4, 1e-4;
  // GIVEN frames of decreasing then increasing size, each matched with the same workspaces
  for (const int n : {300, 40, 260, 5, 300}) {
    std::mt19937 rng(static_cast<uint32_t>(n));
    const auto pts = floorPoints(n, rng);
    std::vector<cv::KeyPoint> left, right;
    for (const auto& p : pts) {
      const auto l = rig.project(p, 0), r = rig.project(p, 1);
      left.emplace_back(cv::Point2f(float(l.x()), float(l.y())), 10.f, -1.f, 0.f, 0, n % 2);
      right.emplace_back(cv::Point2f(float(r.x()), float(r.y()) + 0.3f), 10.f, -1.f, 0.f, 0, n % 2);
    }
    const cv::Mat dl = randomDescriptors(n, rng);
    const cv::Mat dr = perturb(dl, 0.02f, rng);
    // WHEN matched with the reused workspace and with fresh ones
    matchStereo(left, dl, right, dr, rig, StereoMatchParams{}, stereo_ws, stereo_out);
    const auto fresh = matchStereo(left, dl, right, dr, rig, StereoMatchParams{});
    // THEN the stereo points are identical, bit for bit
    ASSERT_EQ(stereo_out.size(), fresh.size()) << n;
    EXPECT_GT(fresh.size(), static_cast<std::size_t>(n) / 8) << n;  // the matcher really worked
    for (std::size_t i = 0; i < fresh.size(); ++i) {
      EXPECT_EQ(stereo_out[i].left_index, fresh[i].left_index);
      EXPECT_EQ(stereo_out[i].right_index, fresh[i].right_index);
      EXPECT_EQ(stereo_out[i].p_R0, fresh[i].p_R0);
    }
    // AND so are the temporal matches, pruned and unpruned
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.0, 0.2, 0.01);
    const TwoFrames f = makeFrames(T, rng);
    for (const bool predict : {true, false}) {
      TemporalMatchParams p;
      p.use_prediction = predict;
      matchTemporal(f.prev, f.curr, rig, T, cov, p, temporal_ws, temporal_out);
      const auto fresh_t = matchTemporal(f.prev, f.curr, rig, T, cov, p);
      ASSERT_EQ(temporal_out.size(), fresh_t.size());
      EXPECT_GT(fresh_t.size(), 150u);
      for (std::size_t i = 0; i < fresh_t.size(); ++i) {
        EXPECT_EQ(temporal_out[i].prev, fresh_t[i].prev);
        EXPECT_EQ(temporal_out[i].curr, fresh_t[i].curr);
        EXPECT_EQ(temporal_out[i].distance, fresh_t[i].distance);
      }
    }
  }
}

}  // namespace
}  // namespace seavio::matching
