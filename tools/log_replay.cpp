#include "tools/log_replay.hpp"

#include <chrono>
#include <cstdio>
#include <thread>

#include <yaml-cpp/yaml.h>

#include "daemon/daemon.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/odometry_processor.hpp"
#include "drivers/config/odometry_config.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/lcm/calibration_msg.hpp"
#include "drivers/lcm/lcm_channels.hpp"
#include "drivers/lcm/lcm_sources.hpp"
#include "tools/lcm_trajectory.hpp"

namespace seavio::tools {

namespace {

using namespace std::chrono_literals;

/// The daemon: and odometry: sections of `path` (defaults without one); errors joined.
bool loadConfig(const std::string& path, daemon::DaemonConfig& cfg, odometry::OdometryParams& params,
                std::string& error) {
  if (path.empty()) return true;
  std::vector<std::string> errors;
  const daemon::DaemonConfigResult loaded = daemon::loadDaemonConfig(path);
  // A file with only an odometry: section is fine here: the daemon: keys are replay's own.
  for (const std::string& e : loaded.errors)
    if (e.find("daemon: section missing") == std::string::npos) errors.push_back(e);
  if (errors.empty()) cfg = loaded.config;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    if (root.IsMap() && root["odometry"]) config::parseOdometryParams(root["odometry"], path, params, errors);
  } catch (const YAML::Exception& e) {
    errors.push_back(path + ": " + e.what());
  }
  for (const std::string& e : errors) error += (error.empty() ? "" : "\n") + e;
  return errors.empty();
}

/// What the replay changes in the daemon's configuration (see the header).
void forReplay(daemon::DaemonConfig& cfg, const LogReplayOptions& o) {
  cfg.processor = "odometry";
  cfg.camera.driver = "lcm";
  cfg.imu.driver = "lcm";
  char speed[32];
  std::snprintf(speed, sizeof speed, "%.17g", o.speed);
  cfg.lcm.input_url = "file://" + o.log + "?speed=" + speed;
  cfg.lcm.url = "file://" + o.pose_log + "?mode=w";
  cfg.backpressure = true;
  cfg.drain_to_newest = false;
  // A stamp-ordered log: wait for the sample after each frame however long the machine takes.
  cfg.imu_wait_ms = 3'600'000;
  cfg.imu_hold_ms = 0;
  // The recorded frames are already on the IMU clock.
  cfg.camera_imu_time_offset_ns = 0;
  cfg.global_thread = false;
  cfg.record = {};
  // A bench machine without privileges: nothing that could be refused.
  cfg.realtime.priority = 0;
  cfg.realtime.lock_memory = false;
}

}  // namespace

LogReplayResult replayLog(const LogReplayOptions& o) {
  LogReplayResult res;
  daemon::DaemonConfig cfg;
  odometry::OdometryParams params;
  if (!loadConfig(o.config, cfg, params, res.error)) return res;
  std::optional<drivers::LogCalibration> calib =
      drivers::readLogCalibration(o.log, std::string(drivers::lcm_channels::kCalibration), &res.error);
  if (!calib && !cfg.calibration_dataset.empty()) {
    // A log without its calibration (lcm-logger on the raw channels): the config names one.
    try {
      const drivers::Dataset ds = drivers::loadDataset(cfg.calibration_dataset);
      calib = drivers::LogCalibration{ds.calibration, ds.imu_noise, false};
      res.error.clear();
    } catch (const std::exception& e) {
      res.error += "; daemon.calibration_dataset: " + std::string(e.what());
    }
  }
  if (!calib) return res;
  res.consumed_order = calib->consumed_order;
  // The loaded keys were validated with the file; what forReplay sets is the replay's own.
  forReplay(cfg, o);
  std::string why;
  std::unique_ptr<daemon::OdometryProcessor> processor =
      daemon::OdometryProcessor::create(calib->stereo, calib->imu_noise, params, &why);
  if (!processor) {
    res.error = o.log + ": calibration unusable: " + why;
    return res;
  }
  const auto t0 = std::chrono::steady_clock::now();
  {
    daemon::Daemon d(cfg,
                     std::make_unique<drivers::LcmStereoSource>(cfg.lcm.input_url, cfg.lcm.stereo_channel,
                                                                cfg.rings.camera_frames, cfg.lcm.imu_channel),
                     std::make_unique<drivers::LcmImuSource>(cfg.lcm.input_url, cfg.lcm.imu_channel, cfg.rings.imu_samples),
                     std::move(processor));
    if (!d.start()) {
      res.error = "replay: " + d.error();
      return res;
    }
    while (!d.finished()) std::this_thread::sleep_for(5ms);
    d.stop();
    res.status = d.statusMessage();
    res.summary = d.summary();
    if (d.accountedFrames() != d.health().frames_in) res.error = "replay: frame accounting mismatch";
  }  // the pose log is complete once the daemon's LCM instance is closed
  res.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  try {
    const DaemonOutputLog out = readDaemonOutputLog(o.pose_log, cfg.lcm.pose_channel, cfg.lcm.status_channel);
    for (const LoggedPose& p : out.poses) res.poses.push_back(p.msg);
    res.trajectory = trajectoryFromLog(out);
  } catch (const std::exception& e) {
    res.error = e.what();
  }
  return res;
}

}  // namespace seavio::tools
