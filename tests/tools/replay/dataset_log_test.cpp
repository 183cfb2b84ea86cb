// GIVEN a small simulated EuRoC sequence, WHEN it is converted to an LCM log, THEN reading the
// log back gives every frame and IMU sample with its timestamp, sequence number and pixels.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "drivers/dataset/dataset.hpp"
#include "drivers/lcm/calibration_msg.hpp"
#include "drivers/lcm/dataset_log.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"
#include "tests/tools/simulate/sim_test_util.hpp"
#include "tools/simulate/sequence_writer.hpp"
#include "replay_test_util.hpp"

namespace seavio::tools {
namespace {

TEST(DatasetLog, RoundTripPreservesTimestampsOrderAndPixels) {
  simulate::test::ScratchDir dir("replay_log");
  simulate::writeSequence(simulate::test::smallConfig(4), dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  ASSERT_EQ(ds.frames.size(), 4u);
  ASSERT_GT(ds.imu.size(), 10u);

  const std::string path = dir.str() + "/seq.lcmlog";
  const drivers::DatasetLogStats st = drivers::writeDatasetLog(ds, path);
  ASSERT_TRUE(st.ok()) << st.error;
  EXPECT_EQ(st.frames, 4u);
  EXPECT_EQ(st.imu_samples, ds.imu.size());

  drivers::LcmLogReader reader(path);
  ASSERT_TRUE(reader.good()) << reader.error();
  std::size_t frames = 0, imu = 0, calibrations = 0;
  int64_t last_t = -1;
  while (auto ev = reader.next()) {
    if (ev->channel == "SEAVIO_STEREO") {
      auto m = reader.decode<seavio_lcm::stereo_t>(*ev);
      ASSERT_TRUE(m);
      auto f = drivers::fromStereoMsg(*m);
      ASSERT_TRUE(f);
      ASSERT_LT(frames, ds.frames.size());
      const StereoFrame want = drivers::loadFrame(ds, frames);
      EXPECT_EQ(f->t_ns, want.t_ns);
      EXPECT_EQ(f->seq, want.seq);
      EXPECT_EQ(ev->t_us, want.t_ns / 1000);
      EXPECT_EQ(cv::norm(f->left, want.left, cv::NORM_INF), 0.0);
      EXPECT_EQ(cv::norm(f->right, want.right, cv::NORM_INF), 0.0);
      EXPECT_GE(f->t_ns, last_t);
      last_t = f->t_ns;
      ++frames;
    } else if (ev->channel == "SEAVIO_IMU") {
      auto m = reader.decode<seavio_lcm::imu_t>(*ev);
      ASSERT_TRUE(m);
      const ImuSample s = drivers::fromImuMsg(*m);
      ASSERT_LT(imu, ds.imu.size());
      EXPECT_EQ(s.t_ns, ds.imu[imu].t_ns);
      EXPECT_EQ(s.gyro_rad_s, ds.imu[imu].gyro_rad_s);
      EXPECT_EQ(s.accel_m_s2, ds.imu[imu].accel_m_s2);
      EXPECT_GE(s.t_ns, last_t);
      last_t = s.t_ns;
      ++imu;
    } else if (ev->channel == "SEAVIO_CALIBRATION") {
      // First, and the dataset's own calibration back, bit for bit.
      EXPECT_EQ(frames + imu, 0u);
      auto m = reader.decode<seavio_lcm::calibration_t>(*ev);
      ASSERT_TRUE(m);
      std::string why;
      const auto c = drivers::fromCalibrationMsg(*m, &why);
      ASSERT_TRUE(c) << why;
      EXPECT_FALSE(c->consumed_order);
      EXPECT_EQ(c->stereo.cam0.fx, ds.calibration.cam0.fx);
      EXPECT_EQ(c->stereo.cam1.cy, ds.calibration.cam1.cy);
      EXPECT_EQ(c->stereo.cam1.model, ds.calibration.cam1.model);
      EXPECT_EQ(c->stereo.cam1.distortion, ds.calibration.cam1.distortion);
      EXPECT_TRUE(c->stereo.T_B_C1.matrix() == ds.calibration.T_B_C1.matrix());
      EXPECT_EQ(c->imu_noise.accelerometer_random_walk, ds.imu_noise.accelerometer_random_walk);
      ++calibrations;
    } else {
      ADD_FAILURE() << "unexpected channel " << ev->channel;
    }
  }
  EXPECT_EQ(frames, 4u);
  EXPECT_EQ(calibrations, 1u);
  EXPECT_EQ(imu, ds.imu.size());
  EXPECT_EQ(reader.decodeFailures(), 0u);
}

TEST(DatasetLog, UnwritableOutputIsAnErrorNamingTheFile) {
  simulate::test::ScratchDir dir("replay_log_bad");
  simulate::writeSequence(simulate::test::smallConfig(2), dir.str(), false);
  const drivers::Dataset ds = drivers::loadEuroc(dir.str());
  const drivers::DatasetLogStats st = drivers::writeDatasetLog(ds, dir.str() + "/no/such/dir/x.lcmlog");
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.error.find("x.lcmlog"), std::string::npos) << st.error;
}

}  // namespace
}  // namespace seavio::tools
