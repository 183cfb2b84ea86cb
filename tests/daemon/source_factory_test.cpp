// daemon::makeSources: every driver named in the config is built (without touching a
// device), profile files are checked up front, and driver faults reach the daemon through
// FaultReporter.
#include "daemon/source_factory.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "daemon/health.hpp"
#include "drivers/lcm/lcm_convert.hpp"
#include "drivers/lcm/lcm_log.hpp"

namespace seavio::daemon {
namespace source_factory_test {
namespace {

using namespace std::chrono_literals;

DaemonConfig liveConfig() {
  DaemonConfig c;
  c.calibration_dataset = "/unused";
  c.camera.driver = "v4l2";
  c.camera.width = 640;
  c.camera.height = 240;
  c.camera.v4l2.device = "/dev/no-such-video-device";
  c.imu.driver = "none";
  return c;
}

std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("seavio_sf_" + std::to_string(getpid()) + "_" + name)).string();
}

TEST(SourceFactory, V4l2CameraIsBuiltAndFailsToStartNamingTheDevice) {
  Sources s = makeSources(liveConfig());
  ASSERT_TRUE(s.error.empty()) << s.error;
  ASSERT_TRUE(s.camera);
  EXPECT_EQ(s.camera->name(), "v4l2:/dev/no-such-video-device");
  EXPECT_NE(dynamic_cast<FaultReporter*>(s.camera.get()), nullptr);
  EXPECT_FALSE(s.camera->start());
  EXPECT_NE(s.camera->lastError().find("/dev/no-such-video-device"), std::string::npos) << s.camera->lastError();
  EXPECT_FALSE(s.imu);
}

#ifdef SEAVIO_HAVE_ARAVIS
TEST(SourceFactory, AravisStereoPairIsBuiltWithoutOpeningTheCameras) {
  DaemonConfig c = liveConfig();
  c.camera.driver = "aravis";
  c.camera.aravis.left = "192.0.2.10";
  c.camera.aravis.right = "192.0.2.11";
  Sources s = makeSources(c);
  ASSERT_TRUE(s.error.empty()) << s.error;
  EXPECT_EQ(s.camera->name(), "aravis:192.0.2.10+192.0.2.11");
  const auto* r = dynamic_cast<FaultReporter*>(s.camera.get());
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->faults().camera_reconnects, 0u);
}
#endif

TEST(SourceFactory, SerialImuReportsFaults) {
  DaemonConfig c = liveConfig();
  c.imu.driver = "serial";
  c.imu.device = "/dev/no-such-tty";
  Sources s = makeSources(c);
  ASSERT_TRUE(s.error.empty()) << s.error;
  ASSERT_TRUE(s.imu);
  EXPECT_EQ(s.imu->name(), "vectornav:/dev/no-such-tty");
  EXPECT_NE(dynamic_cast<FaultReporter*>(s.imu.get()), nullptr);
  EXPECT_FALSE(s.imu->start());
}

TEST(SourceFactory, MissingCanProfileIsAConfigErrorBeforeAnyDevice) {
  DaemonConfig c = liveConfig();
  c.imu.driver = "can";
  c.imu.can_profile = "/no/such/profile.yaml";
  const Sources s = makeSources(c);
  EXPECT_NE(s.error.find("daemon.imu.can_profile"), std::string::npos) << s.error;
  EXPECT_NE(s.error.find("/no/such/profile.yaml"), std::string::npos) << s.error;
}

TEST(SourceFactory, CanImuFromACandumpLogWithTheShippedGenericProfile) {
  // Two samples in the generic layout (config/can_profiles/generic.yaml): time (us),
  // gyro (0.5 mrad/s per LSB), accel (1 mm/s^2 per LSB, emits), plus one malformed line.
  const std::string log = tempPath("imu.log");
  std::ofstream(log) << "(1700000000.000000) can0 102#10270000\n"          // t = 10000 us
                        "(1700000000.000100) can0 100#E803000018FC\n"      // gyro 1000, 0, -1000
                        "(1700000000.000200) can0 101#00000000522600\n"    // accel 0, 0, 9810
                        "this is not candump\n"
                        "(1700000000.005000) can0 102#F8380000\n"          // t = 14584 us
                        "(1700000000.005100) can0 100#E803000018FC\n"
                        "(1700000000.005200) can0 101#00000000522600\n";
  DaemonConfig c = liveConfig();
  c.imu.driver = "can";
  c.imu.can_profile = std::string(SEAVIO_SOURCE_DIR) + "/config/can_profiles/generic.yaml";
  c.imu.candump_log = log;
  Sources s = makeSources(c);
  ASSERT_TRUE(s.error.empty()) << s.error;
  ASSERT_TRUE(s.imu);
  ASSERT_TRUE(s.imu->start()) << s.imu->lastError();
  std::vector<ImuSample> got;
  for (int i = 0; i < 20 && got.size() < 2; ++i) {
    ImuSample x;
    const drivers::ReadStatus st = s.imu->read(x, 100ms);
    if (st == drivers::ReadStatus::kOk) got.push_back(x);
    if (st == drivers::ReadStatus::kEnd || st == drivers::ReadStatus::kError) break;
  }
  ASSERT_EQ(got.size(), 2u);
  EXPECT_NEAR(got[0].gyro_rad_s.x(), 0.5, 1e-9);
  EXPECT_NEAR(got[0].gyro_rad_s.z(), -0.5, 1e-9);
  EXPECT_NEAR(got[0].accel_m_s2.z(), 9.81, 1e-9);
  EXPECT_NEAR(static_cast<double>(got[1].t_ns - got[0].t_ns), 4'584'000.0, 1.0);
  const auto* r = dynamic_cast<FaultReporter*>(s.imu.get());
  ASSERT_NE(r, nullptr);
  EXPECT_GE(r->faults().imu_bus_errors, 1u) << "the malformed line is counted";
  s.imu->stop();
  std::filesystem::remove(log);
}

}  // namespace
}  // namespace source_factory_test
}  // namespace seavio::daemon

namespace seavio::daemon {
namespace source_factory_test {
namespace {

// seaviod replays a recorded log when lcm.input_url names it, while poses still go to lcm.url.
TEST(SourceFactory, LcmInputUrlReplaysALogThroughTheLcmSources) {
  const std::string log = tempPath("in.lcmlog");
  {
    drivers::LcmLogWriter w(log);
    ASSERT_TRUE(w.good()) << w.error();
    StereoFrame f;
    f.t_ns = 1'000'000'000;
    f.seq = 7;
    f.left = cv::Mat(4, 6, CV_8UC1, cv::Scalar(10));
    f.right = cv::Mat(4, 6, CV_8UC1, cv::Scalar(20));
    ImuSample s;
    s.t_ns = 990'000'000;
    s.accel_m_s2.z() = 9.81;
    ASSERT_TRUE(w.write("SEAVIO_IMU", drivers::toImuMsg(s), 990'000));
    ASSERT_TRUE(w.write("SEAVIO_STEREO", drivers::toStereoMsg(f), 1'000'000));
  }
  DaemonConfig c = liveConfig();
  c.camera.driver = "lcm";
  c.imu.driver = "lcm";
  c.lcm.input_url = "file://" + log + "?speed=0";
  Sources s = makeSources(c);
  ASSERT_TRUE(s.error.empty()) << s.error;
  ASSERT_TRUE(s.camera && s.imu);
  ASSERT_TRUE(s.camera->start()) << s.camera->lastError();
  ASSERT_TRUE(s.imu->start()) << s.imu->lastError();
  StereoFrame f;
  ASSERT_EQ(s.camera->read(f, 2s), drivers::ReadStatus::kOk) << s.camera->lastError();
  EXPECT_EQ(f.seq, 7u);
  EXPECT_EQ(f.right.at<uint8_t>(3, 5), 20);
  EXPECT_EQ(s.camera->read(f, 2s), drivers::ReadStatus::kEnd);
  ImuSample imu;
  ASSERT_EQ(s.imu->read(imu, 2s), drivers::ReadStatus::kOk) << s.imu->lastError();
  EXPECT_EQ(imu.t_ns, 990'000'000);
  s.camera->stop();
  s.imu->stop();
  std::filesystem::remove(log);
}

TEST(SourceFactory, LcmInputUrlWithoutAnLcmDriverIsAConfigError) {
  DaemonConfig c = liveConfig();
  c.lcm.input_url = "file:///tmp/x.lcmlog";
  std::vector<std::string> errors;
  validateDaemonConfig(c, "seavio.yaml", errors);
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors.front().find("daemon.lcm.input_url"), std::string::npos) << errors.front();
}

}  // namespace
}  // namespace source_factory_test
}  // namespace seavio::daemon
