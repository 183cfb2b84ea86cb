#pragma once
/// The `daemon:` section of config/seavio.yaml: drivers, LCM, rings, threads, watchdog and
/// time offset. Loaded and validated before any device is opened.
#include <cstdint>
#include <string>
#include <vector>

#include "daemon/degrade_ladder.hpp"
#include "daemon/realtime.hpp"
#include "daemon/record_config.hpp"
#include "daemon/ring_capacities.hpp"

namespace seavio::daemon {

/// `camera.aravis`: a GigE Vision stereo pair (two cameras paired by device timestamp, free
/// running or both on one hardware trigger line), or one camera delivering side by side.
struct AravisSection {
  std::string left;             ///< Aravis device id or IP address of the left camera
  std::string right;            ///< right camera; empty = `left` delivers left | right
  double exposure_us = 0;       ///< [us], 0 = keep the camera's setting
  std::string trigger_source;   ///< e.g. "Line1" for a hardware-triggered pair; empty = free running
  int packet_size = 0;          ///< GVSP packet size [bytes], 0 = camera default
  int socket_buffer_bytes = 0;  ///< receive buffer [bytes], 0 = automatic
  double pair_tolerance_ms = 10;  ///< left/right mapped stamps further apart are not a pair [ms]
  int reconnect_after_ms = 1000;  ///< a camera silent this long is reopened [ms]
  int clock_init_frames = 20;     ///< frames that settle each device clock before pairing
};

/// `camera.v4l2`: a side-by-side stereo capture device.
struct V4l2Section {
  std::string device = "/dev/video0";
  std::string pixel_format = "GREY";  ///< GREY or YUYV
};

/// `camera.libcamera`: a side-by-side stereo camera behind libcamera.
struct LibcameraSection {
  std::string camera_id;  ///< empty = the first camera found
};

/// Camera input. driver: "dataset" (EuRoC/ASL or KITTI folder, replayed with pacing),
/// "lcm" (seavio_lcm::stereo_t on `lcm.stereo_channel`, e.g. from lcm-logplayer), "aravis"
/// (GigE Vision), "v4l2" or "libcamera" (when built).
struct CameraConfig {
  std::string driver = "dataset";
  std::string dataset;        ///< dataset folder (driver "dataset")
  double replay_speed = 1.0;  ///< 1 = real time, N = N x, 0 = as fast as possible
  /// Image size [px] per camera (aravis, 0 = keep the camera's) or of the whole
  /// side-by-side image (v4l2, libcamera: required, even).
  int width = 0;
  int height = 0;
  double frame_rate_hz = 15;  ///< free-running rate requested from the device [Hz]
  int buffers = 8;            ///< device/stream buffers
  AravisSection aravis;
  V4l2Section v4l2;
  LibcameraSection libcamera;
};

/// IMU input. driver: "dataset" (the camera's dataset), "lcm" (seavio_lcm::imu_t), "serial"
/// (VectorNav binary), "can" (SocketCAN with a profile), or "none" (vision only).
struct ImuConfig {
  std::string driver = "dataset";
  std::string device = "/dev/ttyUSB0";  ///< driver "serial"
  int baud = 921600;                    ///< driver "serial" [bit/s]
  /// driver "serial": if > 0, configure the sensor's binary output to 800 Hz / divisor
  /// at start; 0 keeps its stored configuration.
  int rate_divisor = 0;
  std::string interface = "can0";  ///< driver "can": SocketCAN interface
  std::string can_profile;         ///< driver "can": profile YAML (config/can_profiles/)
  std::string candump_log;         ///< driver "can": replay this candump file instead of a bus
  /// A live IMU silent this long is dead [ms]: flagged in the status (imu_dead) and, with
  /// `dead_policy` exit, the daemon exits (kExitImuDead) so systemd restarts it.
  int dead_after_ms = 1000;
  /// "flag": report and carry on vision-only (the pose stays continuous; the drivers keep
  /// reconnecting); "exit": stop feeding the watchdog and exit for a restart.
  std::string dead_policy = "flag";
};

struct LcmConfig {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";  ///< where poses and status go
  /// Where camera/IMU driver "lcm" reads; empty = `url`. "file://LOG?speed=S" replays a
  /// recorded log through the same sources (S = 1 real time, N = N x, 0 = as fast as possible).
  std::string input_url;
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
  /// File replay only (camera.driver dataset, or lcm reading a file:// input_url): the camera
  /// and IMU threads wait for room in their ring instead of dropping, so with drain_to_newest
  /// false every frame is processed (deterministic replay). Never for live sensors, whose
  /// acquisition must not block.
  bool backpressure = false;
  /// How long the estimator waits for IMU samples to reach a frame's time [ms].
  int imu_wait_ms = 20;
  /// The estimator waits for the first IMU sample after a frame (the odometry interpolates
  /// at the frame time) unless the newest sample is at most this much older than the frame
  /// [ms]; then the odometry holds that sample's rates up to the frame time. 0 = always wait
  /// (deterministic replay: the same IMU hand-over as `seavio run`). Live with a 200 Hz IMU,
  /// 5 saves up to 5 ms of every frame's latency (cost in git history of docs/benchmarks.md).
  int imu_hold_ms = 0;
  /// Odometry mode global only: run the global step (revisit re-observation, ICP against the
  /// map, keyframe insertion) on its own thread. The local pose of every frame goes
  /// out at once flagged FLAG_LOCAL_ONLY, the refined one when the ICP thread is done, flagged
  /// FLAG_GLOBAL_REFINED (same seq). false: inline in the estimator, one pose per frame.
  bool global_thread = true;
  /// Thread scheduling and memory locking of the frame path (daemon/realtime.hpp).
  RealtimeConfig realtime;
  /// Recording of what the estimator consumes (daemon/recorder.hpp); off by default.
  RecordConfig record;
  /// The per-frame budget, its misses and the degrade ladder (daemon/degrade_ladder.hpp).
  /// Never degrades with `backpressure` (file replay: no deadline, and the poses must not
  /// depend on the host's load).
  DeadlineConfig deadline;
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

/// Camera drivers compiled into this build, as "dataset, lcm, ..., v4l2," (trailing comma).
std::string cameraDriversBuilt();

/// Every effective value, one "daemon.key = value" per line, for the start-up log.
std::string describe(const DaemonConfig& c);

}  // namespace seavio::daemon
