// GIVEN rendered frames and the calibration written for them, THEN rectified stereo
// correspondences share a row and ground-truth motion predicts where the floor moves.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/camera/stereo_rectifier.hpp"
#include "drivers/dataset/dataset.hpp"
#include "sim_test_util.hpp"
#include "tools/simulate/seafloor_renderer.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "tools/simulate/trajectory.hpp"

namespace seavio::simulate {
namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// Sub-pixel location of `patch` in `image` near `guess` (normalised cross-correlation with
/// a parabola through the peak); false if the peak is weak or on the window border.
bool locate(const cv::Mat& patch, const cv::Mat& image, const Eigen::Vector2d& guess, int search,
            Eigen::Vector2d* found) {
  const int half = patch.cols / 2;
  const int x0 = static_cast<int>(std::lround(guess.x())) - half - search;
  const int y0 = static_cast<int>(std::lround(guess.y())) - half - search;
  const cv::Rect roi(x0, y0, patch.cols + 2 * search, patch.rows + 2 * search);
  if (roi.x < 0 || roi.y < 0 || roi.br().x > image.cols || roi.br().y > image.rows) return false;
  cv::Mat score;
  cv::matchTemplate(image(roi), patch, score, cv::TM_CCOEFF_NORMED);
  double best;
  cv::Point p;
  cv::minMaxLoc(score, nullptr, &best, nullptr, &p);
  if (best < 0.7 || p.x < 1 || p.y < 1 || p.x >= score.cols - 1 || p.y >= score.rows - 1) return false;
  auto peak = [](float l, float c, float r) { return 0.5 * (l - r) / (l - 2 * c + r); };
  const double dx = peak(score.at<float>(p.y, p.x - 1), score.at<float>(p.y, p.x), score.at<float>(p.y, p.x + 1));
  const double dy = peak(score.at<float>(p.y - 1, p.x), score.at<float>(p.y, p.x), score.at<float>(p.y + 1, p.x));
  *found = {x0 + p.x + dx + half, y0 + p.y + dy + half};
  return true;
}

TEST(SimulatorGeometry, RectifiedStereoCorrespondencesShareARow) {
  // GIVEN a tilted rig and the calibration written to disk and read back by the EuRoC reader.
  test::ScratchDir dir("rows");
  SimConfig c = test::smallConfig(1, 640, 480);
  c.rig.tilt_deg = 15;
  writeSequence(c, dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  std::string error;
  const auto rectifier = camera::StereoRectifier::create(ds.calibration, &error);
  ASSERT_TRUE(rectifier.has_value()) << error;
  // WHEN true floor points are projected with the simulator's own model.
  const StereoRigModel rig(c.rig);
  SeafloorRenderer renderer(c, rig);
  const Trajectory traj(c.trajectory, renderer.seafloor().relief(), 20.0);
  const Eigen::Isometry3d T_W_B = traj.at(12.0).T_W_B();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(0, 1);
  double worst = 0;
  int used = 0;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector2d uv0(20 + 600 * U(rng), 20 + 440 * U(rng));
    const Eigen::Isometry3d T_W_C0 = T_W_B * rig.T_B_C(0);
    const auto X = renderer.intersect(T_W_C0.translation(), T_W_C0.rotation() * renderer.pixelRay(0, uv0.x(), uv0.y()));
    ASSERT_TRUE(X.has_value());
    const Eigen::Vector3d p1 = (T_W_B * rig.T_B_C(1)).inverse() * *X;
    const Eigen::Vector2d uv1 = rig.project(1, p1);
    if (uv1.x() < 0 || uv1.y() < 0 || uv1.x() > 639 || uv1.y() > 479) continue;
    // THEN after rectification they lie on the same row.
    const Eigen::Vector2d r0 = rectifier->rectifyPoint(0, uv0), r1 = rectifier->rectifyPoint(1, uv1);
    worst = std::max(worst, std::abs(r0.y() - r1.y()));
    EXPECT_GT(r0.x() - r1.x(), 0.0);  // positive disparity
    ++used;
  }
  EXPECT_GT(used, 150);
  EXPECT_LT(worst, 0.3);
}

TEST(SimulatorGeometry, GroundTruthPredictsTrackedFloorInNextFrameAndOtherCamera) {
  // GIVEN two consecutive rendered stereo frames on the cruise leg of the short preset.
  SimConfig c = presetConfig("short-plain");
  const StereoRigModel rig(c.rig);
  SeafloorRenderer renderer(c, rig);
  const Trajectory traj(c.trajectory, renderer.seafloor().relief(), 20.0);
  const double t0 = 12.0, t1 = 12.1;
  const Eigen::Isometry3d T_W_B0 = traj.at(t0).T_W_B(), T_W_B1 = traj.at(t1).T_W_B();
  cv::Mat l0, l1, r0;
  renderer.render(0, T_W_B0, t0, 1, l0);
  renderer.render(0, T_W_B1, t1, 2, l1);
  renderer.render(1, T_W_B0, t0, 3, r0);
  const Eigen::Isometry3d T_W_C0 = T_W_B0 * rig.T_B_C(0);
  const Eigen::Isometry3d T_C0next_W = (T_W_B1 * rig.T_B_C(0)).inverse();
  const Eigen::Isometry3d T_C1_W = (T_W_B0 * rig.T_B_C(1)).inverse();
  std::vector<double> temporal, stereo;
  const int half = 10;
  for (int v = 60; v <= 420; v += 30)
    for (int u = 60; u <= 580; u += 30) {
      // WHEN a floor patch of the left image is located in the next left and the right image.
      const auto X = renderer.intersect(T_W_C0.translation(), T_W_C0.rotation() * renderer.pixelRay(0, u, v));
      ASSERT_TRUE(X.has_value());
      const cv::Mat patch = l0(cv::Rect(u - half, v - half, 2 * half + 1, 2 * half + 1));
      Eigen::Vector2d found;
      const Eigen::Vector2d pred_t = rig.project(0, T_C0next_W * *X);
      if (locate(patch, l1, pred_t, 6, &found)) temporal.push_back((found - pred_t).norm());
      const Eigen::Vector2d pred_s = rig.project(1, T_C1_W * *X);
      if (locate(patch, r0, pred_s, 6, &found)) stereo.push_back((found - pred_s).norm());
    }
  // THEN the ground truth predicts the tracked location within half a pixel (median).
  ASSERT_GT(temporal.size(), 100u);
  ASSERT_GT(stereo.size(), 100u);
  EXPECT_LT(median(temporal), 0.5);
  EXPECT_LT(median(stereo), 0.5);
}

}  // namespace
}  // namespace seavio::simulate
