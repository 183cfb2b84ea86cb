#include <gtest/gtest.h>

#include "daemon/daemon_config.hpp"

namespace seavio::daemon {
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

TEST(DaemonConfig, DescribeListsEffectiveValues) {
  DaemonConfig c;
  c.lcm.url = "udpm://239.1.2.3:7000?ttl=0";
  const std::string d = describe(c);
  EXPECT_NE(d.find("daemon.lcm.url = udpm://239.1.2.3:7000?ttl=0"), std::string::npos);
  EXPECT_NE(d.find("daemon.rings.camera_frames = 4"), std::string::npos);
}

}  // namespace
}  // namespace seavio::daemon
