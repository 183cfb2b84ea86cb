#include <gtest/gtest.h>

#include "daemon/daemon_config.hpp"

namespace seavio::daemon {
namespace daemon_config_test {
namespace {

bool anyContains(const std::vector<std::string>& errors, const std::string& needle) {
  for (const auto& e : errors)
    if (e.find(needle) != std::string::npos) return true;
  return false;
}

TEST(DaemonConfig, ShippedConfigIsValid) {
  const auto r = loadDaemonConfig(std::string(SEAVIO_SOURCE_DIR) + "/config/seavio.yaml");
  for (const auto& e : r.errors) ADD_FAILURE() << e;
  EXPECT_EQ(r.config.lcm.url, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_EQ(r.config.rings.camera_frames, 4u);
}

TEST(DaemonConfig, MinimalSectionKeepsDefaults) {
  const auto r = parseDaemonConfig(
      "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n", "t.yaml");
  ASSERT_TRUE(r.ok()) << r.errors.front();
  EXPECT_EQ(r.config.camera.driver, "lcm");
  EXPECT_EQ(r.config.rings.imu_samples, RingCapacities{}.imu_samples);
  EXPECT_EQ(r.config.status_period_ms, 1000);
}

TEST(DaemonConfig, AllErrorsAtOnceEachNamingFileAndKey) {
  const std::string y =
      "daemon:\n"
      "  camera: {driver: gige, replay_speed: -1}\n"
      "  imu: {driver: carrier_pigeon, baud: abc}\n"
      "  lcm: {url: ''}\n"
      "  rings: {camera_frames: 0, imu_samples: -5}\n"
      "  threads: {workers: 99}\n"
      "  status_period_ms: 5\n"
      "  camera_imu_time_offset_ns: 5000000000\n"
      "  typo_key: 1\n";
  const auto r = parseDaemonConfig(y, "bad.yaml");
  EXPECT_FALSE(r.ok());
  for (const char* key : {"daemon.camera.driver", "daemon.camera.replay_speed", "daemon.imu.driver",
                          "daemon.imu.baud", "daemon.lcm.url", "daemon.rings.camera_frames",
                          "daemon.rings.imu_samples", "daemon.threads.workers",
                          "daemon.status_period_ms", "daemon.camera_imu_time_offset_ns",
                          "daemon.typo_key"}) {
    EXPECT_TRUE(anyContains(r.errors, std::string("bad.yaml: ") + key)) << key;
  }
  EXPECT_TRUE(anyContains(r.errors, "line 3")) << "bad scalar names its line";
}

TEST(DaemonConfig, DeadImuAndDeadlineKeysAreReadAndChecked) {
  const auto ok = parseDaemonConfig(
      "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n"
      "  imu: {driver: lcm, dead_after_ms: 300, dead_policy: exit}\n"
      "  deadline: {frame_budget_ms: 50, window_frames: 10, release_fraction: 0.5, feature_fraction: 0.5, degrade: false}\n",
      "ok.yaml");
  ASSERT_TRUE(ok.ok()) << ok.errors.front();
  EXPECT_EQ(ok.config.imu.dead_after_ms, 300);
  EXPECT_EQ(ok.config.imu.dead_policy, "exit");
  EXPECT_EQ(ok.config.deadline.frame_budget_ms, 50);
  EXPECT_EQ(ok.config.deadline.window_frames, 10);
  EXPECT_FALSE(ok.config.deadline.degrade);
  EXPECT_NE(describe(ok.config).find("daemon.deadline.frame_budget_ms = 50"), std::string::npos);
  EXPECT_EQ(DaemonConfig{}.deadline.frame_budget_ms, 66);
  const auto bad = parseDaemonConfig(
      "daemon:\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n"
      "  imu: {driver: lcm, dead_after_ms: 5, dead_policy: reboot}\n"
      "  deadline: {frame_budget_ms: 0, window_frames: 2, release_fraction: 1.5, feature_fraction: 0, degrad: 1}\n",
      "bad.yaml");
  for (const char* key : {"daemon.imu.dead_after_ms", "daemon.imu.dead_policy", "daemon.deadline.frame_budget_ms",
                          "daemon.deadline.window_frames", "daemon.deadline.release_fraction",
                          "daemon.deadline.feature_fraction", "daemon.deadline.degrad: unknown key"}) {
    EXPECT_TRUE(anyContains(bad.errors, std::string("bad.yaml: ") + key)) << key;
  }
}

TEST(DaemonConfig, SyntaxErrorNamesFileAndLine) {
  const auto r = parseDaemonConfig("daemon:\n  camera: [driver\n  x: 1\n", "syn.yaml");
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(anyContains(r.errors, "syn.yaml: line")) << r.errors.front();
}

TEST(DaemonConfig, MissingSectionAndMissingFile) {
  EXPECT_TRUE(anyContains(parseDaemonConfig("odometry: {}\n", "o.yaml").errors, "o.yaml: daemon"));
  EXPECT_TRUE(anyContains(loadDaemonConfig("/no/such/seavio.yaml").errors, "/no/such/seavio.yaml"));
  EXPECT_FALSE(parseDaemonConfig("daemon: 3\n", "s.yaml").ok());
}

TEST(DaemonConfig, DatasetDriverNeedsAPath) {
  const auto r = parseDaemonConfig("daemon:\n  camera: {driver: dataset}\n", "d.yaml");
  EXPECT_TRUE(anyContains(r.errors, "d.yaml: daemon.camera.dataset"));
}

TEST(DaemonConfig, OdometryWithoutDatasetNeedsACalibration) {
  const auto r = parseDaemonConfig("daemon:\n  camera: {driver: lcm}\n  processor: magic\n", "p.yaml");
  EXPECT_TRUE(anyContains(r.errors, "p.yaml: daemon.processor: 'magic'"));
  const auto q = parseDaemonConfig("daemon:\n  camera: {driver: lcm}\n", "q.yaml");
  EXPECT_TRUE(anyContains(q.errors, "q.yaml: daemon.calibration_dataset"));
  const auto ok = parseDaemonConfig("daemon:\n  camera: {driver: lcm}\n  imu: {driver: none}\n  calibration_dataset: /x\n", "k.yaml");
  EXPECT_TRUE(ok.ok());
}

TEST(DaemonConfig, LiveDriversParseIntoTheirSections) {
  const auto r = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /calib\n"
      "  camera:\n    driver: aravis\n    width: 640\n    height: 480\n    frame_rate_hz: 15\n    buffers: 6\n"
      "    aravis: {left: 10.0.0.5, right: Basler-acA-123, exposure_us: 800, trigger_source: Line1,\n"
      "             packet_size: 8000, socket_buffer_bytes: 4000000, pair_tolerance_ms: 5,\n"
      "             reconnect_after_ms: 700, clock_init_frames: 7}\n"
      "  imu: {driver: can, interface: can1, can_profile: /etc/seavio/xsens.yaml}\n",
      "live.yaml");
  ASSERT_TRUE(r.ok()) << r.errors.front();
  const DaemonConfig& c = r.config;
  EXPECT_EQ(c.camera.aravis.left, "10.0.0.5");
  EXPECT_EQ(c.camera.aravis.right, "Basler-acA-123");
  EXPECT_EQ(c.camera.aravis.trigger_source, "Line1");
  EXPECT_EQ(c.camera.aravis.packet_size, 8000);
  EXPECT_DOUBLE_EQ(c.camera.aravis.pair_tolerance_ms, 5.0);
  EXPECT_EQ(c.camera.aravis.clock_init_frames, 7);
  EXPECT_EQ(c.camera.buffers, 6);
  EXPECT_EQ(c.imu.interface, "can1");
  EXPECT_EQ(c.imu.can_profile, "/etc/seavio/xsens.yaml");
  const std::string d = describe(c);
  EXPECT_NE(d.find("daemon.camera.aravis.left = 10.0.0.5"), std::string::npos);
  EXPECT_NE(d.find("daemon.imu.can_profile = /etc/seavio/xsens.yaml"), std::string::npos);

  const auto v = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /c\n  camera: {driver: v4l2, width: 1280, height: 480,\n"
      "    v4l2: {device: /dev/video2, pixel_format: YUYV}}\n  imu: {driver: serial, device: /dev/ttyS1, rate_divisor: 4}\n",
      "v.yaml");
  ASSERT_TRUE(v.ok()) << v.errors.front();
  EXPECT_EQ(v.config.camera.v4l2.device, "/dev/video2");
  EXPECT_EQ(v.config.imu.rate_divisor, 4);
}

TEST(DaemonConfig, LiveDriverErrorsNameFileAndKey) {
  const auto r = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /c\n"
      "  camera:\n    driver: aravis\n    width: 641\n    frame_rate_hz: 15\n    buffers: 1\n"
      "    aravis: {exposure_us: -3, packet_size: 12, pair_tolerance_ms: 40, reconnect_after_ms: 5,\n"
      "             clock_init_frames: 0, colour: red}\n"
      "  imu: {driver: can, interface: a_very_long_interface_name}\n",
      "live.yaml");
  EXPECT_FALSE(r.ok());
  for (const char* key : {"daemon.camera.aravis.left", "daemon.camera.width", "daemon.camera.height",
                          "daemon.camera.buffers", "daemon.camera.aravis.exposure_us", "daemon.camera.aravis.packet_size",
                          "daemon.camera.aravis.pair_tolerance_ms", "daemon.camera.aravis.reconnect_after_ms",
                          "daemon.camera.aravis.clock_init_frames", "daemon.camera.aravis.colour: unknown key",
                          "daemon.imu.can_profile", "daemon.imu.interface"}) {
    EXPECT_TRUE(anyContains(r.errors, std::string("live.yaml: ") + key)) << key;
  }
  const auto v = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /c\n  camera: {driver: v4l2, v4l2: {device: '', pixel_format: MJPG}}\n"
      "  imu: {driver: none}\n",
      "v.yaml");
  for (const char* key : {"daemon.camera.width", "daemon.camera.height", "daemon.camera.v4l2.device",
                          "daemon.camera.v4l2.pixel_format"}) {
    EXPECT_TRUE(anyContains(v.errors, std::string("v.yaml: ") + key)) << key;
  }
  // Live sensors never wait for ring room.
  const auto b = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /c\n  camera: {driver: v4l2, width: 640, height: 480}\n  backpressure: true\n",
      "b.yaml");
  EXPECT_TRUE(anyContains(b.errors, "b.yaml: daemon.backpressure"));
}

TEST(DaemonConfig, CameraDriversBuiltListsTheLiveOnes) {
  const std::string d = cameraDriversBuilt();
  EXPECT_NE(d.find("dataset, lcm,"), std::string::npos);
  EXPECT_NE(d.find("v4l2,"), std::string::npos);
#ifdef SEAVIO_HAVE_ARAVIS
  EXPECT_NE(d.find("aravis,"), std::string::npos);
#endif
#ifdef SEAVIO_HAVE_LIBCAMERA
  EXPECT_NE(d.find("libcamera,"), std::string::npos);
#else
  EXPECT_TRUE(anyContains(parseDaemonConfig("daemon:\n  calibration_dataset: /c\n  camera: {driver: libcamera}\n", "l.yaml").errors,
                          "not built in"));
#endif
}

TEST(DaemonConfig, DescribeListsEffectiveValues) {
  DaemonConfig c;
  c.lcm.url = "udpm://239.1.2.3:7000?ttl=0";
  const std::string d = describe(c);
  EXPECT_NE(d.find("daemon.lcm.url = udpm://239.1.2.3:7000?ttl=0"), std::string::npos);
  EXPECT_NE(d.find("daemon.rings.camera_frames = 4"), std::string::npos);
}

}  // namespace
}  // namespace daemon_config_test
}  // namespace seavio::daemon
