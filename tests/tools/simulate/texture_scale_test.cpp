// GIVEN the full paper survey and the same survey shortened by `bench paper --scale` (legs,
// lane spacing and frames times the scale, turn limits divided by it), THEN the floor the
// camera sees at a given place is the same in both, and as textured 400 m down the first leg
// as at the start: the floor is a function of (x, y, seed) sampled at a fixed 7.5 mm, not a
// raster stretched over the survey area. (the full survey's first 300 frames drifted
// ~10x more than the scaled one's; the floor is not why, see docs/simulator.md.)
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/simulate/seafloor_renderer.hpp"

namespace seavio::simulate {
namespace {

/// The scaled paper config as `seavio bench paper --scale` builds it (tools/bench_report.cpp).
SimConfig scaledPaper(double scale) {
  SimConfig c = presetConfig("paper-plain");
  c.frames = static_cast<int>(std::lround(c.frames * scale));
  c.trajectory.leg_length_m *= scale;
  c.trajectory.leg_spacing_m *= scale;
  c.trajectory.max_yaw_rate_rad_s /= scale;
  c.trajectory.max_yaw_accel_rad_s2 /= scale * scale;
  return c;
}

/// Level body `altitude` above the relief at (x, y), heading +x.
Eigen::Isometry3d levelAt(const SeafloorRenderer& r, double x, double y, double altitude) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, r.seafloor().relief().height(x, y) + altitude);
  return T;
}

/// Texture at camera scale: standard deviation of the image minus its 9x9 box blur [DN]
/// (what SURF's smallest box filters and the matcher's descriptors see).
double highPassStd(const cv::Mat& img) {
  cv::Mat f, blur;
  img.convertTo(f, CV_32F);
  cv::blur(f, blur, cv::Size(9, 9));
  cv::Scalar mean, stddev;
  cv::meanStdDev(f - blur, mean, stddev);
  return stddev[0];
}

TEST(TextureScale, SamePlaceSameImageWhateverTheSurveySize) {
  const SimConfig full = scaledPaper(1.0), tenth = scaledPaper(0.1);
  const StereoRigModel rig(full.rig);
  SeafloorRenderer a(full, rig), b(tenth, rig);
  for (const double x : {0.0, 37.5, 412.0}) {
    cv::Mat ia, ib;
    a.render(0, levelAt(a, x, 0.0, 4.0), 0.0, 7, ia);
    b.render(0, levelAt(b, x, 0.0, 4.0), 0.0, 7, ib);
    EXPECT_EQ(cv::norm(ia, ib, cv::NORM_INF), 0.0) << "x = " << x;
  }
}

TEST(TextureScale, FarDownTheLegAsTexturedAsAtTheStart) {
  const SimConfig c = presetConfig("paper-plain");
  const StereoRigModel rig(c.rig);
  SeafloorRenderer r(c, rig);
  // Average over a few places per region: single views differ by the rocks they contain.
  auto texture = [&](double x0) {
    double sum = 0;
    for (int k = 0; k < 4; ++k) {
      cv::Mat img;
      r.render(0, levelAt(r, x0 + 6.0 * k, 0.0, 4.0), 0.0, static_cast<uint64_t>(k), img);
      sum += highPassStd(img);
    }
    return sum / 4;
  };
  const double near = texture(10.0), far = texture(400.0), side = texture(-250.0);
  EXPECT_GT(near, 3.0);  // clearly above the 1.5 DN sensor noise
  EXPECT_NEAR(far / near, 1.0, 0.25);
  EXPECT_NEAR(side / near, 1.0, 0.25);
}

}  // namespace
}  // namespace seavio::simulate
