#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "drivers/lcm/lcm_convert.hpp"

namespace seavio::drivers {
namespace lcm_convert_test {
namespace {

OdometryResult sampleResult() {
  OdometryResult r;
  r.t_ns = 1'234'567'890;
  r.seq = 42;
  r.T_W_B = Eigen::Isometry3d::Identity();
  r.T_W_B.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  r.T_W_B.translation() = Eigen::Vector3d(1.5, -2.0, 0.25);
  r.v_W = Eigen::Vector3d(0.1, 0.2, -0.3);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) r.covariance(i, j) = (i == j) ? 0.01 * (i + 1) : 0.001 * (i + j);
  r.source = PoseSource::kVision;
  r.quality.features_left = 500;
  r.quality.ransac_inliers = 120;
  r.quality.icp_inliers = 80;
  r.quality.map_refined = true;
  r.times.total_ms = 33.0;
  return r;
}

TEST(LcmConvert, PoseRoundTripKeepsPoseCovarianceAndFlags) {
  // GIVEN a visual odometry result refined by ICP
  const OdometryResult r = sampleResult();
  // WHEN it goes through an encoded pose_t and back
  seavio_lcm::pose_t m = toPoseMsg(r, 99);
  std::vector<uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  ASSERT_GT(m.encode(buf.data(), 0, static_cast<int>(buf.size())), 0);
  seavio_lcm::pose_t d;
  ASSERT_GT(d.decode(buf.data(), 0, static_cast<int>(buf.size())), 0);
  const OdometryResult back = fromPoseMsg(d);
  // THEN everything published is preserved
  EXPECT_EQ(d.version, int16_t{seavio_lcm::pose_t::VERSION});
  EXPECT_EQ(d.publish_t_ns, 99);
  EXPECT_EQ(back.seq, 42u);
  EXPECT_EQ(back.t_ns, r.t_ns);
  EXPECT_TRUE(back.T_W_B.isApprox(r.T_W_B, 1e-12));
  EXPECT_TRUE(back.v_W.isApprox(r.v_W));
  EXPECT_TRUE(back.covariance.isApprox(r.covariance));
  EXPECT_EQ(back.source, PoseSource::kVision);
  EXPECT_TRUE(d.flags & seavio_lcm::pose_t::FLAG_VISUAL);
  EXPECT_TRUE(d.flags & seavio_lcm::pose_t::FLAG_GLOBAL_REFINED);
  EXPECT_FALSE(d.flags & seavio_lcm::pose_t::FLAG_LOCAL_ONLY);
  EXPECT_TRUE(back.quality.map_refined);
  EXPECT_EQ(d.ransac_inliers, 120);
  EXPECT_DOUBLE_EQ(d.processing_ms, 33.0);
}

TEST(LcmConvert, NonFinitePoseIsNeverPublishedAndIsFlagged) {
  OdometryResult r = sampleResult();
  r.T_W_B.translation().x() = std::numeric_limits<double>::quiet_NaN();
  const seavio_lcm::pose_t m = toPoseMsg(r, 0);
  for (double v : m.position) EXPECT_TRUE(std::isfinite(v));
  for (double v : m.covariance) EXPECT_TRUE(std::isfinite(v));
  EXPECT_TRUE(m.flags & seavio_lcm::pose_t::FLAG_IMU_ONLY);
  EXPECT_FALSE(m.flags & seavio_lcm::pose_t::FLAG_VISUAL);
  EXPECT_GT(m.covariance[0], 1e6);
}

TEST(LcmConvert, ImuOnlyAndLocalOnlyFlags) {
  OdometryResult r = sampleResult();
  r.source = PoseSource::kImuOnly;
  r.quality.icp_inliers = 0;
  r.quality.map_refined = false;
  const seavio_lcm::pose_t m = toPoseMsg(r, 0);
  EXPECT_EQ(m.flags, static_cast<int32_t>(seavio_lcm::pose_t::FLAG_IMU_ONLY) |
                         static_cast<int32_t>(seavio_lcm::pose_t::FLAG_LOCAL_ONLY));
  // Frame-to-frame ICP (local mode) is not a global refinement.
  r.source = PoseSource::kVision;
  r.quality.icp_inliers = 80;
  EXPECT_TRUE(toPoseMsg(r, 0).flags & seavio_lcm::pose_t::FLAG_LOCAL_ONLY);
}

TEST(LcmConvert, StereoRoundTripIsBitExact) {
  StereoFrame f;
  f.t_ns = 77;
  f.seq = 3;
  f.left = cv::Mat(4, 6, CV_8UC1);
  f.right = cv::Mat(4, 6, CV_8UC1);
  cv::randu(f.left, 0, 255);
  cv::randu(f.right, 0, 255);
  const seavio_lcm::stereo_t m = toStereoMsg(f, 1500.0);
  EXPECT_EQ(m.width, 6);
  EXPECT_EQ(m.height, 4);
  EXPECT_EQ(m.left_size, 24);
  EXPECT_DOUBLE_EQ(m.exposure_us, 1500.0);
  const auto back = fromStereoMsg(m);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->t_ns, 77);
  EXPECT_EQ(back->seq, 3u);
  EXPECT_EQ(cv::norm(back->left, f.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back->right, f.right, cv::NORM_INF), 0.0);
}

TEST(LcmConvert, NonContinuousImagesAreCopiedRowByRow) {
  cv::Mat big(8, 8, CV_8UC1);
  cv::randu(big, 0, 255);
  StereoFrame f;
  f.left = big(cv::Rect(1, 1, 5, 4));
  f.right = big(cv::Rect(2, 2, 5, 4));
  ASSERT_FALSE(f.left.isContinuous());
  const auto back = fromStereoMsg(toStereoMsg(f));
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(cv::norm(back->left, f.left, cv::NORM_INF), 0.0);
}

TEST(LcmConvert, InconsistentStereoSizesAreRejectedWithReason) {
  seavio_lcm::stereo_t m{};
  m.width = 10;
  m.height = 10;
  m.left_size = 100;
  m.left.resize(100);
  m.right_size = 50;
  m.right.resize(50);
  std::string why;
  EXPECT_FALSE(fromStereoMsg(m, &why).has_value());
  EXPECT_NE(why.find("right_size=50"), std::string::npos) << why;
}

TEST(LcmConvert, ImuRoundTrip) {
  ImuSample s;
  s.t_ns = 5;
  s.gyro_rad_s = Eigen::Vector3d(0.1, 0.2, 0.3);
  s.accel_m_s2 = Eigen::Vector3d(-1, 0, 9.81);
  const ImuSample b = fromImuMsg(toImuMsg(s));
  EXPECT_EQ(b.t_ns, 5);
  EXPECT_EQ(b.gyro_rad_s, s.gyro_rad_s);
  EXPECT_EQ(b.accel_m_s2, s.accel_m_s2);
}

}  // namespace
}  // namespace lcm_convert_test
}  // namespace seavio::drivers

namespace seavio::drivers {
namespace lcm_convert_test {
namespace {

TEST(LcmConvert, PoseTimingListsStagesAndAcquisitionOnlyOnTheDaemonClock) {
  OdometryResult r;
  r.t_ns = 1'000'000'000;
  r.times.rectify_ms = 1;
  r.times.features_ms = 20;
  r.times.stereo_ms = 3;
  r.times.temporal_ms = 4;
  r.times.tensor_ms = 5;
  r.times.icp_ms = 6;
  r.times.total_ms = 40;
  // Captured at 1.000 s, received 5 ms later, odometry done 50 ms after receipt, published 1 ms later.
  const int64_t recv = 1'005'000'000, end = 1'055'000'000, pub = 1'056'000'000;
  seavio_lcm::pose_t m = toPoseMsg(r, pub);
  setPoseTiming(m, r.times, recv, end, pub);
  EXPECT_EQ(m.recv_t_ns, recv);
  ASSERT_EQ(m.num_stages, 9);
  EXPECT_EQ(m.stage_names, (std::vector<std::string>{"acquisition", "queue", "rectify", "features", "stereo",
                                                     "temporal", "tensor", "icp", "publish"}));
  EXPECT_NEAR(m.stage_ms[0], 5.0, 1e-9);
  EXPECT_NEAR(m.stage_ms[1], 10.0, 1e-9);  // 50 ms receipt to end, 40 ms of it odometry
  EXPECT_NEAR(m.stage_ms[3], 20.0, 1e-9);
  EXPECT_NEAR(m.stage_ms[8], 1.0, 1e-9);
  // Round trip through the wire format.
  std::vector<uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  ASSERT_GE(m.encode(buf.data(), 0, static_cast<int>(buf.size())), 0);
  seavio_lcm::pose_t back{};
  ASSERT_GE(back.decode(buf.data(), 0, static_cast<int>(buf.size())), 0);
  EXPECT_EQ(back.stage_names, m.stage_names);
  EXPECT_EQ(back.version, 2);
  // A replayed dataset's stamp (another epoch): no acquisition stage; no odometry split: only queue and publish.
  r.t_ns = 1'403'636'579'763'555'584;  // EuRoC-style Unix epoch stamp
  r.times = StageTimes{};
  seavio_lcm::pose_t n = toPoseMsg(r, pub);
  setPoseTiming(n, r.times, recv, end, pub);
  EXPECT_EQ(n.stage_names, (std::vector<std::string>{"queue", "publish"}));
  EXPECT_NEAR(n.stage_ms[0], 50.0, 1e-9);
}

}  // namespace
}  // namespace lcm_convert_test
}  // namespace seavio::drivers
