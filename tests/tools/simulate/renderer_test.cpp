// GIVEN the procedural seafloor and renderer, THEN images carry features at survey altitudes,
// marine snow appears only when asked and at the true disparity, and renders are repeatable.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "tools/simulate/seafloor_renderer.hpp"
#include "tools/simulate/trajectory.hpp"

namespace seavio::simulate {
namespace {

/// Level body at (3, 2) in W, `altitude` above the relief.
Eigen::Isometry3d poseAtAltitude(const SeafloorRenderer& r, double altitude) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(3.0, 2.0, r.seafloor().relief().height(3.0, 2.0) + altitude);
  return T;
}

TEST(SeafloorRenderer, ImagesHaveHundredsOfCornersFromTwoToEightMetres) {
  for (double altitude : {2.0, 4.0, 8.0}) {
    SimConfig c = presetConfig("short-plain");
    c.trajectory.altitude_m = altitude;  // exposure follows the nominal altitude
    const StereoRigModel rig(c.rig);
    SeafloorRenderer r(c, rig);
    cv::Mat img;
    r.render(0, poseAtAltitude(r, altitude), 0.0, 1, img);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(img, corners, 3000, 0.01, 5);
    EXPECT_GT(corners.size(), 300u) << altitude;
    const double mean = cv::mean(img)[0];
    EXPECT_GT(mean, 40) << altitude;
    EXPECT_LT(mean, 200) << altitude;
  }
}

TEST(SeafloorRenderer, SnowOnlyWhenEnabledAboutTwelveHundredPerImage) {
  SimConfig plain = presetConfig("short-plain"), snow = presetConfig("short-snow");
  const StereoRigModel rig(plain.rig);
  SeafloorRenderer rp(plain, rig), rs(snow, rig);
  cv::Mat a, b;
  const Eigen::Isometry3d T = poseAtAltitude(rs, 4.0);
  EXPECT_EQ(rp.render(0, T, 5.0, 1, a), 0);
  const int n0 = rs.render(0, T, 5.0, 1, b);
  const int n1 = rs.render(1, T, 5.0, 2, b);
  EXPECT_GT(n0, 900);
  EXPECT_LT(n0, 1500);
  EXPECT_NEAR(n1, n0, 0.1 * n0);
  // Snow brightens and changes the image.
  EXPECT_GT(cv::norm(a, b, cv::NORM_L1), 0.0);
}

TEST(SeafloorRenderer, SameKeySameImageAndNoiseChangesWithKey) {
  const SimConfig c = presetConfig("short-snow");
  const StereoRigModel rig(c.rig);
  SeafloorRenderer r1(c, rig), r2(c, rig);
  cv::Mat a, b, d;
  const Eigen::Isometry3d T = poseAtAltitude(r1, 4.0);
  r1.render(0, T, 3.0, 42, a);
  r2.render(0, T, 3.0, 42, b);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  r2.render(0, T, 3.0, 43, d);
  EXPECT_GT(cv::norm(a, d, cv::NORM_INF), 0.0);
  EXPECT_LT(cv::norm(a, d, cv::NORM_L1) / a.total(), 4.0);  // only sensor noise differs
}

TEST(SeafloorRenderer, SameBytesWithOneOrTwoThreads) {
  // Rows and tile bands are shaded in parallel: the split must not change a single pixel.
  const SimConfig c = presetConfig("short-snow");
  const StereoRigModel rig(c.rig);
  const int before = cv::getNumThreads();
  cv::Mat img[2][2];
  for (int threads : {1, 2}) {
    cv::setNumThreads(threads);
    SeafloorRenderer r(c, rig);  // fresh tile cache: tile generation is split too
    const Eigen::Isometry3d T = poseAtAltitude(r, 4.0);
    r.render(0, T, 2.0, 5, img[threads - 1][0]);
    r.render(1, T, 2.0, 6, img[threads - 1][1]);
  }
  cv::setNumThreads(before);
  EXPECT_EQ(cv::norm(img[0][0], img[1][0], cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(img[0][1], img[1][1], cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(img[0][0], img[0][1], cv::NORM_L1), 0.0);  // two different cameras
}

TEST(Seafloor, CachedAndDirectLookupsAgree) {
  const SimConfig c = presetConfig("short-plain");
  Seafloor floor(c.seafloor, c.seed);
  const FloorSample direct = floor.sample(1.2345, -0.678);
  floor.prepare(0, -1, 2, 0);
  const FloorSample cached = floor.sample(1.2345, -0.678);
  EXPECT_GT(floor.cachedTiles(), 0);
  EXPECT_NEAR(direct.h, cached.h, 1e-6);
  EXPECT_NEAR(direct.albedo, cached.albedo, 1e-6);
  // Whole rows of a tile, across pebbles and rocks, against the direct evaluation.
  float max_dh = 0, max_da = 0;
  const Seafloor fresh(c.seafloor, c.seed);  // never prepared: direct evaluation
  for (int k = 0; k < 2000; ++k) {
    const double x = 0.0011 + 0.000997 * k, y = -0.9 + 0.0004 * k;
    const FloorSample d = fresh.sample(x, y), t = floor.sample(x, y);
    max_dh = std::max(max_dh, std::abs(d.h - t.h));
    max_da = std::max(max_da, std::abs(d.albedo - t.albedo));
  }
  EXPECT_LT(max_dh, 1e-6);
  EXPECT_LT(max_da, 1e-6);
  Seafloor other(c.seafloor, c.seed + 1);
  EXPECT_NE(other.sample(1.2345, -0.678).albedo, direct.albedo);  // the seed matters
}

}  // namespace
}  // namespace seavio::simulate
