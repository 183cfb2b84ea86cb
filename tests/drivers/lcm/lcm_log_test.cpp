#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"
#include "seavio_lcm/imu_t.hpp"
#include "seavio_lcm/stereo_t.hpp"

namespace seavio::drivers {
namespace lcm_log_test {
namespace {

std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("seavio_lcmlog_" + std::to_string(getpid()) + "_" + name))
      .string();
}

void writeSampleLog(const std::string& path, int n_imu) {
  LcmLogWriter w(path);
  ASSERT_TRUE(w.good()) << w.error();
  for (int i = 0; i < n_imu; ++i) {
    ImuSample s;
    s.t_ns = 1'000'000LL * i;
    s.gyro_rad_s.x() = 0.01 * i;
    ASSERT_TRUE(w.write("SEAVIO_IMU", toImuMsg(s), s.t_ns / 1000));
  }
  StereoFrame f;
  f.t_ns = 5'000'000;
  f.seq = 7;
  f.left = cv::Mat(3, 4, CV_8UC1, cv::Scalar(10));
  f.right = cv::Mat(3, 4, CV_8UC1, cv::Scalar(20));
  ASSERT_TRUE(w.write("SEAVIO_STEREO", toStereoMsg(f), 5000));
  EXPECT_EQ(w.eventsWritten(), static_cast<uint64_t>(n_imu + 1));
}

TEST(LcmLog, WriteThenReadPreservesChannelsTimesAndPayloads) {
  const std::string path = tempPath("ok.lcmlog");
  writeSampleLog(path, 10);
  LcmLogReader r(path);
  ASSERT_TRUE(r.good()) << r.error();
  int imu = 0, stereo = 0;
  while (auto ev = r.next()) {
    if (ev->channel == "SEAVIO_IMU") {
      auto m = r.decode<seavio_lcm::imu_t>(*ev);
      ASSERT_TRUE(m.has_value());
      EXPECT_EQ(m->t_ns, 1'000'000LL * imu);
      EXPECT_EQ(ev->t_us, 1000LL * imu);
      EXPECT_DOUBLE_EQ(m->gyro_rad_s[0], 0.01 * imu);
      ++imu;
    } else if (ev->channel == "SEAVIO_STEREO") {
      auto m = r.decode<seavio_lcm::stereo_t>(*ev);
      ASSERT_TRUE(m.has_value());
      auto f = fromStereoMsg(*m);
      ASSERT_TRUE(f.has_value());
      EXPECT_EQ(f->seq, 7u);
      EXPECT_EQ(f->right.at<uint8_t>(2, 3), 20);
      ++stereo;
    }
  }
  EXPECT_EQ(imu, 10);
  EXPECT_EQ(stereo, 1);
  EXPECT_EQ(r.decodeFailures(), 0u);
  std::filesystem::remove(path);
}

TEST(LcmLog, MessageOfTheWrongTypeIsCountedNotCrashing) {
  const std::string path = tempPath("wrongtype.lcmlog");
  writeSampleLog(path, 2);
  LcmLogReader r(path);
  ASSERT_TRUE(r.good());
  auto ev = r.next();
  ASSERT_TRUE(ev.has_value());
  // An imu_t payload decoded as stereo_t fails the fingerprint check.
  EXPECT_FALSE(r.decode<seavio_lcm::stereo_t>(*ev).has_value());
  EXPECT_EQ(r.decodeFailures(), 1u);
  std::filesystem::remove(path);
}

TEST(LcmLog, TruncatedLogEndsEarlyWithoutCrash) {
  const std::string path = tempPath("trunc.lcmlog");
  writeSampleLog(path, 10);
  const auto full = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, full - 7);  // cut inside the stereo event
  LcmLogReader r(path);
  ASSERT_TRUE(r.good());
  int n = 0;
  while (auto ev = r.next()) ++n;
  EXPECT_EQ(n, 10);  // every complete IMU event, the torn stereo event dropped
  std::filesystem::remove(path);
}

TEST(LcmLog, GarbageInTheMiddleIsSkipped) {
  const std::string path = tempPath("garbage.lcmlog");
  writeSampleLog(path, 3);
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::string damaged = std::string(37, '\x5a') + bytes;
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << damaged;
  }
  LcmLogReader r(path);
  ASSERT_TRUE(r.good());
  int n = 0;
  while (auto ev = r.next()) ++n;
  EXPECT_EQ(n, 4);  // the reader resynchronises on the event sync word
  std::filesystem::remove(path);
}

TEST(LcmLog, MissingFileNamesThePath) {
  LcmLogReader r("/nonexistent/dir/x.lcmlog");
  EXPECT_FALSE(r.good());
  EXPECT_NE(r.error().find("/nonexistent/dir/x.lcmlog"), std::string::npos);
  EXPECT_FALSE(r.next().has_value());
}

}  // namespace
}  // namespace lcm_log_test
}  // namespace seavio::drivers
