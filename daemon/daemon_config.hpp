#pragma once
/// The `daemon:` section of config/seavio.yaml: drivers, LCM, rings, threads, watchdog and
/// time offset. Loaded and validated before any device is opened (issue 6, issue 9).
#include <cstdint>
#include <string>
#include <vector>

#include "daemon/ring_capacities.hpp"

namespace seavio::daemon {

/// Camera input. driver: "dataset" (EuRoC/ASL or KITTI folder, replayed with pacing) or
/// "lcm" (seavio_lcm::stereo_t on `lcm.stereo_channel`, e.g. from lcm-logplayer).
struct CameraConfig {
  std::string driver = "dataset";
  std::string dataset;        ///< dataset folder (driver "dataset")
  double replay_speed = 1.0;  ///< 1 = real time, N = N x, 0 = as fast as possible
};

/// IMU input. driver: "dataset" (the camera's dataset), "lcm" (seavio_lcm::imu_t), "serial"
/// (VectorNav binary), or "none" (vision only).
struct ImuConfig {
  std::string driver = "dataset";
  std::string device = "/dev/ttyUSB0";  ///< driver "serial"
  int baud = 921600;                    ///< driver "serial" [bit/s]
};

struct LcmConfig {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  std::string pose_channel = "SEAVIO_POSE";
  std::string status_channel = "SEAVIO_STATUS";
  std::string stereo_channel = "SEAVIO_STEREO";
  std::string imu_channel = "SEAVIO_IMU";
};

struct DaemonConfig {
  /// Estimator: "odometry" (core stereo visual odometry, paper Sec. III) or
  /// "imu_dead_reckoning" (no vision; every pose flagged IMU-only).
  std::string processor = "odometry";
  /// EuRoC/ASL or KITTI folder whose calibration the odometry uses when the camera driver is
  /// not "dataset" (e.g. lcm); empty = the camera dataset's own calibration.
  std::string calibration_dataset;
  CameraConfig camera;
  ImuConfig imu;
  LcmConfig lcm;
  RingCapacities rings;
  int worker_threads = 2;            ///< left/right image preparation in parallel
  /// WATCHDOG=1 is sent only if a frame arrived and a pose was published within this
  /// time [ms]: a stalled pipeline lets systemd restart us.
  int watchdog_stall_ms = 2000;
  int status_period_ms = 1000;       ///< status_t and STATUS= period [ms]
  /// Added to camera timestamps to put them on the IMU clock [ns] (t_imu = t_cam + offset).
  int64_t camera_imu_time_offset_ns = 0;
  int imu_gap_ms = 50;               ///< IMU step above this counts as a gap [ms]
  int frame_gap_ms = 500;            ///< frame step above this counts as a gap [ms]
  /// true: the estimator always takes the newest frame, older ones counted as dropped
  /// (live). false: every frame in order (replay); the camera ring still never blocks.
  bool drain_to_newest = true;
  /// File replay only: the camera and IMU threads wait for room in their ring instead of
  /// dropping, so with drain_to_newest false every frame is processed (deterministic replay).
  /// Never for live sensors, whose acquisition must not block.
  bool backpressure = false;
  /// How long the estimator waits for IMU samples to reach a frame's time [ms].
  int imu_wait_ms = 20;
};

struct DaemonConfigResult {
  DaemonConfig config;
  std::vector<std::string> errors;  ///< each "FILE: daemon.KEY: reason"; empty = valid
  bool ok() const { return errors.empty(); }
};

/// Loads the `daemon:` section of `path`; every missing key keeps its default, every bad or
/// unknown key is an error. All errors are returned at once; the file is never partially
/// trusted.
DaemonConfigResult loadDaemonConfig(const std::string& path);
/// Same from YAML text; `origin` names the source in errors.
DaemonConfigResult parseDaemonConfig(const std::string& yaml_text, const std::string& origin);
/// Checks values (ranges, driver names); appends errors prefixed with `origin`.
void validateDaemonConfig(const DaemonConfig& c, const std::string& origin,
                          std::vector<std::string>& errors);

/// Every effective value, one "daemon.key = value" per line, for the start-up log.
std::string describe(const DaemonConfig& c);

}  // namespace seavio::daemon
