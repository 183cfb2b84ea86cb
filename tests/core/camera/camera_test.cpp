#include <random>
#include <stdexcept>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera/camera_model.hpp"
#include "core/camera/stereo_rectifier.hpp"

namespace seavio::camera {
namespace {

/// EuRoC MH_01 cam0 / cam1 (radial-tangential).
StereoCalibration eurocCalibration() {
  StereoCalibration c;
  c.cam0 = {752, 480, 458.654, 457.296, 367.215, 248.375, DistortionModel::kRadialTangential,
            {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05}};
  c.cam1 = {752, 480, 457.587, 456.134, 379.999, 255.238, DistortionModel::kRadialTangential,
            {-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05}};
  // Camera poses in the body: cam1 ~11 cm to the right with a small relative rotation.
  c.T_B_C0.linear() = Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  c.T_B_C0.translation() = Eigen::Vector3d(-0.02, -0.06, 0.01);
  const Eigen::Isometry3d T_C0_C1 = [] {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.01, Eigen::Vector3d(1, -0.5, 0.7).normalized()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.110, 0.0005, -0.0008);
    return T;
  }();
  c.T_B_C1 = c.T_B_C0 * T_C0_C1;
  return c;
}

StereoCalibration fisheyeCalibration() {
  StereoCalibration c = eurocCalibration();
  for (CameraIntrinsics* cam : {&c.cam0, &c.cam1}) {
    cam->model = DistortionModel::kEquidistant;
    cam->distortion = {-0.0048, 0.0103, -0.0115, 0.0043};
  }
  c.cam1.distortion = {-0.0052, 0.0098, -0.0109, 0.0039};
  return c;
}

void expectUndistortRoundTrip(const CameraIntrinsics& cam) {
  double worst = 0;
  for (int v = 0; v <= cam.height; v += 16) {
    for (int u = 0; u <= cam.width; u += 16) {
      const Eigen::Vector2d uv(u, v);
      const Eigen::Vector2d xy = cam.undistortToNormalized(uv);
      const Eigen::Vector2d back = cam.project(Eigen::Vector3d(xy.x(), xy.y(), 1.0) * 3.0);
      worst = std::max(worst, (back - uv).norm());
    }
  }
  EXPECT_LT(worst, 0.01) << toString(cam.model);
}

TEST(CameraModel, RadtanDistortUndistortRoundTripOverImage) {
  expectUndistortRoundTrip(eurocCalibration().cam0);
}

TEST(CameraModel, EquidistantDistortUndistortRoundTripOverImage) {
  expectUndistortRoundTrip(fisheyeCalibration().cam0);
}

TEST(CameraModel, ProjectMatchesOpenCv) {
  // GIVEN the same camera in seavio and OpenCV, WHEN projecting, THEN the pixels agree.
  const CameraIntrinsics cam = eurocCalibration().cam0;
  std::vector<cv::Point3d> pts{{0.3, -0.2, 1.0}, {-0.6, 0.4, 1.2}, {0.01, 0.02, 5.0}};
  std::vector<cv::Point2d> px;
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cam.K(), cam.D(), px);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector2d uv = cam.project({pts[i].x, pts[i].y, pts[i].z});
    EXPECT_NEAR(uv.x(), px[i].x, 1e-9);
    EXPECT_NEAR(uv.y(), px[i].y, 1e-9);
  }
}

TEST(CameraModel, NoDistortionIsPinhole) {
  CameraIntrinsics cam{640, 480, 500, 510, 320, 240, DistortionModel::kNone, {0, 0, 0, 0}};
  const Eigen::Vector2d uv = cam.project({0.2, -0.1, 2.0});
  EXPECT_NEAR(uv.x(), 320 + 500 * 0.1, 1e-12);
  EXPECT_NEAR(uv.y(), 240 - 510 * 0.05, 1e-12);
  EXPECT_EQ(cam.K().at<double>(1, 1), 510);
  EXPECT_EQ(cam.D().cols, 4);
}

TEST(CameraModel, ParseDistortionModelNames) {
  EXPECT_EQ(parseDistortionModel("radial-tangential"), DistortionModel::kRadialTangential);
  EXPECT_EQ(parseDistortionModel("radtan"), DistortionModel::kRadialTangential);
  EXPECT_EQ(parseDistortionModel("equidistant"), DistortionModel::kEquidistant);
  EXPECT_EQ(parseDistortionModel("none"), DistortionModel::kNone);
  EXPECT_FALSE(parseDistortionModel("pinhole-bogus").has_value());
  for (auto m : {DistortionModel::kNone, DistortionModel::kRadialTangential, DistortionModel::kEquidistant})
    EXPECT_EQ(parseDistortionModel(toString(m)), m);
}

/// Rectified pixel of camera `cam` -> raw distorted pixel, the inverse of rectifyPoint.
Eigen::Vector2d unrectify(const StereoRectifier& r, int cam, const Eigen::Vector2d& uv) {
  const RectifiedRig& rig = r.rig();
  const Eigen::Vector3d p_R((uv.x() - rig.cx) / rig.f_px, (uv.y() - rig.cy) / rig.f_px, 1.0);
  const Eigen::Matrix3d R = cam == 0 ? r.R_R0_C0() : r.R_R1_C1();
  const CameraIntrinsics& c = cam == 0 ? r.calibration().cam0 : r.calibration().cam1;
  return c.project(R.transpose() * p_R);
}

void expectRectifyRoundTrips(const StereoCalibration& calib) {
  std::string error;
  const auto r = StereoRectifier::create(calib, &error);
  ASSERT_TRUE(r) << error;
  double worst_point = 0, worst_map = 0;
  for (int cam = 0; cam < 2; ++cam) {
    for (int v = 20; v < calib.cam0.height - 20; v += 23) {
      for (int u = 20; u < calib.cam0.width - 20; u += 23) {
        const Eigen::Vector2d raw(u, v);
        worst_point = std::max(worst_point, (unrectify(*r, cam, r->rectifyPoint(cam, raw)) - raw).norm());
        // The remap tables say where rectified pixel (u, v) samples the raw image.
        const Eigen::Vector2d rect(u, v);
        worst_map = std::max(worst_map, (r->rectifyPoint(cam, unrectify(*r, cam, rect)) - rect).norm());
      }
    }
  }
  EXPECT_LT(worst_point, 0.01);
  EXPECT_LT(worst_map, 0.01);
}

TEST(StereoRectifier, RadtanRectifyRoundTrips) { expectRectifyRoundTrips(eurocCalibration()); }
TEST(StereoRectifier, EquidistantRectifyRoundTrips) { expectRectifyRoundTrips(fisheyeCalibration()); }

TEST(StereoRectifier, RemapTableAgreesWithRectifyPoint) {
  // GIVEN a raw image with one bright dot, WHEN rectified, THEN the dot lands at rectifyPoint.
  const StereoCalibration calib = eurocCalibration();
  std::string error;
  const auto r = StereoRectifier::create(calib, &error);
  ASSERT_TRUE(r) << error;
  const Eigen::Vector2d raw(500, 150);
  cv::Mat img(480, 752, CV_8UC1, cv::Scalar(0));
  cv::circle(img, cv::Point(500, 150), 4, cv::Scalar(255), cv::FILLED);
  cv::Mat l, rr;
  r->rectify(img, img, l, rr);
  const cv::Moments m = cv::moments(l, false);
  ASSERT_GT(m.m00, 0);
  const Eigen::Vector2d expect = r->rectifyPoint(0, raw);
  EXPECT_NEAR(m.m10 / m.m00, expect.x(), 0.3);
  EXPECT_NEAR(m.m01 / m.m00, expect.y(), 0.3);
  EXPECT_EQ(l.size(), img.size());
}

void expectSameRowAndTriangulation(const StereoCalibration& calib) {
  std::string error;
  const auto r = StereoRectifier::create(calib, &error);
  ASSERT_TRUE(r) << error;
  const RectifiedRig& rig = r->rig();
  EXPECT_NEAR(rig.baseline_m, (calib.T_B_C1.inverse() * calib.T_B_C0).translation().norm(), 1e-9);
  const Eigen::Isometry3d T_C1_C0 = calib.T_B_C1.inverse() * calib.T_B_C0;
  // T_B_R0 shares cam0's centre and differs from it by the rectifying rotation only.
  EXPECT_LT((rig.T_B_R0.translation() - calib.T_B_C0.translation()).norm(), 1e-15);
  EXPECT_LT((rig.T_B_R0.linear() - calib.T_B_C0.linear() * r->R_R0_C0().transpose()).norm(), 1e-15);

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-1.0, 1.0), uz(2.0, 12.0);
  int tested = 0;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p_C0(ux(rng), uy(rng), uz(rng));
    const Eigen::Vector3d p_C1 = T_C1_C0 * p_C0;
    const Eigen::Vector2d raw0 = calib.cam0.project(p_C0), raw1 = calib.cam1.project(p_C1);
    auto inside = [&](const Eigen::Vector2d& uv) {
      return uv.x() > 5 && uv.y() > 5 && uv.x() < calib.cam0.width - 5 && uv.y() < calib.cam0.height - 5;
    };
    if (!inside(raw0) || !inside(raw1)) continue;
    ++tested;
    const Eigen::Vector2d rect0 = r->rectifyPoint(0, raw0), rect1 = r->rectifyPoint(1, raw1);
    EXPECT_NEAR(rect0.y(), rect1.y(), 0.01);
    const Eigen::Vector3d p_R0 = rig.triangulate(rect0, rect0.x() - rect1.x());
    const Eigen::Vector3d expect_R0 = r->R_R0_C0() * p_C0;
    EXPECT_LT((p_R0 - expect_R0).norm(), 1e-4 * p_C0.z());
    // And back through the body frame: the same physical point.
    EXPECT_LT((rig.T_B_R0 * p_R0 - calib.T_B_C0 * p_C0).norm(), 1e-4 * p_C0.z());
    EXPECT_LT((rig.project(p_R0, 1) - rect1).norm(), 0.01);
  }
  EXPECT_GT(tested, 100);
}

TEST(StereoRectifier, RadtanPointsLandOnSameRowAndTriangulate) {
  expectSameRowAndTriangulation(eurocCalibration());
}
TEST(StereoRectifier, EquidistantPointsLandOnSameRowAndTriangulate) {
  expectSameRowAndTriangulation(fisheyeCalibration());
}

TEST(StereoRectifier, RejectsUnusableCalibration) {
  StereoCalibration calib = eurocCalibration();
  std::string error;
  calib.cam1.width = 640;
  EXPECT_FALSE(StereoRectifier::create(calib, &error));
  EXPECT_NE(error.find("resolution"), std::string::npos);

  calib = eurocCalibration();
  calib.T_B_C1 = calib.T_B_C0;
  EXPECT_FALSE(StereoRectifier::create(calib, &error));
  EXPECT_NE(error.find("baseline"), std::string::npos);

  calib = eurocCalibration();
  calib.cam0.fx = 0;
  EXPECT_FALSE(StereoRectifier::create(calib, &error));
  EXPECT_NE(error.find("cam0"), std::string::npos);

  calib = eurocCalibration();
  std::swap(calib.T_B_C0, calib.T_B_C1);  // right camera on the left
  EXPECT_FALSE(StereoRectifier::create(calib, &error));
}

}  // namespace
}  // namespace seavio::camera
