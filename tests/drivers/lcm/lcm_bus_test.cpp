// Real UDP multicast on loopback, inside the private network namespace set up by
// netns_environment.cpp.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "drivers/lcm/lcm_bus.hpp"
#include "drivers/lcm/lcm_channels.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_sources.hpp"

namespace seavio::drivers {
namespace lcm_bus_test {
namespace {

const std::string kUrl(lcm_channels::kDefaultUrl);

TEST(LcmBus, PoseCrossesUdpMulticastOnLoopback) {
  LcmBus pub(kUrl), sub(kUrl);
  ASSERT_TRUE(pub.good());
  ASSERT_TRUE(sub.good());
  int received = 0;
  int64_t seq = -1;
  sub.subscribe<seavio_lcm::pose_t>("SEAVIO_POSE", [&](const seavio_lcm::pose_t& m) {
    ++received;
    seq = m.seq;
  });
  OdometryResult r;
  r.seq = 17;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (received == 0 && std::chrono::steady_clock::now() < deadline) {
    ASSERT_TRUE(pub.publish("SEAVIO_POSE", toPoseMsg(r, 0)));
    sub.handle(100);
  }
  EXPECT_GE(received, 1);
  EXPECT_EQ(seq, 17);
  EXPECT_EQ(pub.publishFailures(), 0u);
}

TEST(LcmBus, GarbageOnAChannelIsCountedAsDecodeFailure) {
  LcmBus pub(kUrl), sub(kUrl);
  ASSERT_TRUE(sub.good());
  int received = 0;
  sub.subscribe<seavio_lcm::pose_t>("SEAVIO_POSE", [&](const seavio_lcm::pose_t&) { ++received; });
  seavio_lcm::imu_t wrong = toImuMsg(ImuSample{});
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (sub.decodeFailures() == 0 && std::chrono::steady_clock::now() < deadline) {
    pub.publish("SEAVIO_POSE", wrong);
    sub.handle(100);
  }
  EXPECT_GE(sub.decodeFailures(), 1u);
  EXPECT_EQ(received, 0);
}

TEST(LcmBus, BadProviderIsNotGoodAndPublishIsCountedAsFailure) {
  LcmBus bad("nosuchprovider://x");
  EXPECT_FALSE(bad.good());
  EXPECT_FALSE(bad.publish("X", toImuMsg(ImuSample{})));
  EXPECT_EQ(bad.publishFailures(), 1u);
  EXPECT_EQ(bad.handle(10), -1);
}

TEST(LcmSources, StereoAndImuSourcesReadWhatIsPublished) {
  LcmStereoSource cam(kUrl, "SEAVIO_STEREO");
  LcmImuSource imu(kUrl, "SEAVIO_IMU");
  ASSERT_TRUE(cam.start()) << cam.lastError();
  ASSERT_TRUE(imu.start()) << imu.lastError();
  LcmBus pub(kUrl);
  StereoFrame f;
  f.seq = 5;
  f.t_ns = 123;
  f.left = cv::Mat(8, 8, CV_8UC1, cv::Scalar(1));
  f.right = cv::Mat(8, 8, CV_8UC1, cv::Scalar(2));
  ImuSample s;
  s.t_ns = 456;
  // Publish from another thread while the sources read with timeouts.
  std::thread t([&] {
    for (int i = 0; i < 20; ++i) {
      pub.publish("SEAVIO_STEREO", toStereoMsg(f));
      pub.publish("SEAVIO_IMU", toImuMsg(s));
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  StereoFrame got;
  ReadStatus st = ReadStatus::kTimeout;
  for (int i = 0; i < 40 && st != ReadStatus::kOk; ++i) st = cam.read(got, std::chrono::milliseconds(50));
  ImuSample gs;
  ReadStatus si = ReadStatus::kTimeout;
  for (int i = 0; i < 40 && si != ReadStatus::kOk; ++i) si = imu.read(gs, std::chrono::milliseconds(50));
  t.join();
  ASSERT_EQ(st, ReadStatus::kOk);
  ASSERT_EQ(si, ReadStatus::kOk);
  EXPECT_EQ(got.seq, 5u);
  EXPECT_EQ(got.right.at<uint8_t>(7, 7), 2);
  EXPECT_EQ(gs.t_ns, 456);
  cam.stop();
  imu.stop();
  EXPECT_EQ(cam.read(got, std::chrono::milliseconds(1)), ReadStatus::kError);
}

TEST(LcmSources, ReadTimesOutWhenNothingArrives) {
  LcmImuSource imu(kUrl, "SEAVIO_IMU_SILENT");
  ASSERT_TRUE(imu.start());
  ImuSample s;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(imu.read(s, std::chrono::milliseconds(30)), ReadStatus::kTimeout);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(1));
}

}  // namespace
}  // namespace lcm_bus_test
}  // namespace seavio::drivers
