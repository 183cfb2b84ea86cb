// `daemon.record` and replay's blocking pushes in the daemon config: parsed, validated with the
// file and key named, listed in the start-up description; the shipped config leaves recording off.
#include <gtest/gtest.h>

#include <algorithm>

#include "daemon/daemon_config.hpp"

namespace seavio::daemon {
namespace {

bool anyHas(const std::vector<std::string>& v, const std::string& s) {
  return std::any_of(v.begin(), v.end(), [&](const std::string& e) { return e.find(s) != std::string::npos; });
}

TEST(RecordConfig, ParsedValidatedAndDescribed) {
  const auto r = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /c\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n"
      "  record: {path: /var/log/seavio/dive.lcmlog, max_file_mb: 200, max_files: 3, ring_items: 512, ring_frames: 8}\n",
      "r.yaml");
  ASSERT_TRUE(r.ok()) << r.errors.front();
  EXPECT_TRUE(r.config.record.enabled());
  EXPECT_EQ(r.config.record.path, "/var/log/seavio/dive.lcmlog");
  EXPECT_DOUBLE_EQ(r.config.record.max_file_mb, 200.0);
  EXPECT_EQ(r.config.record.max_files, 3);
  EXPECT_EQ(r.config.record.ring_items, 512u);
  EXPECT_EQ(r.config.record.ring_frames, 8u);
  EXPECT_NE(describe(r.config).find("daemon.record.path = /var/log/seavio/dive.lcmlog"), std::string::npos);

  const auto bad = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /c\n  processor: imu_dead_reckoning\n  camera: {driver: lcm}\n"
      "  imu: {driver: lcm}\n  record: {path: /x.lcmlog, max_file_mb: 0.5, max_files: 0, ring_items: 4,"
      " ring_frames: 8, size: 3}\n",
      "b.yaml");
  for (const char* key : {"b.yaml: daemon.record.path", "b.yaml: daemon.record.max_file_mb",
                          "b.yaml: daemon.record.max_files", "b.yaml: daemon.record.ring_items",
                          "b.yaml: daemon.record.size: unknown key"})
    EXPECT_TRUE(anyHas(bad.errors, key)) << key;

  const auto off = loadDaemonConfig(std::string(SEAVIO_SOURCE_DIR) + "/config/seavio.yaml");
  ASSERT_TRUE(off.ok()) << off.errors.front();
  EXPECT_FALSE(off.config.record.enabled());
}

TEST(RecordConfig, BlockingPushesOnlyForFileReplay) {
  const auto file = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /c\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n  backpressure: true\n"
      "  lcm: {input_url: \"file:///data/dive.lcmlog?speed=0\"}\n",
      "f.yaml");
  EXPECT_TRUE(file.ok()) << file.errors.front();
  const auto live = parseDaemonConfig(
      "daemon:\n  calibration_dataset: /c\n  camera: {driver: lcm}\n  imu: {driver: lcm}\n  backpressure: true\n",
      "l.yaml");
  EXPECT_TRUE(anyHas(live.errors, "l.yaml: daemon.backpressure")) << "LCM over UDP is live input";
}

}  // namespace
}  // namespace seavio::daemon
