#include "daemon/daemon_config.hpp"

#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

namespace seavio::daemon {

namespace {

class Reader {
 public:
  Reader(std::string origin, std::vector<std::string>& errors)
      : origin_(std::move(origin)), errors_(errors) {}

  void error(const std::string& key, const std::string& what) {
    errors_.push_back(origin_ + ": " + key + ": " + what);
  }

  /// Flags keys of `node` not in `known`.
  void onlyKeys(const YAML::Node& node, const std::string& prefix,
                const std::set<std::string>& known) {
    if (!node) return;
    if (!node.IsMap()) {
      error(prefix, "must be a mapping");
      return;
    }
    for (const auto& kv : node) {
      const std::string k = kv.first.as<std::string>("");
      if (!known.count(k)) error(prefix + "." + k, "unknown key");
    }
  }

  template <class T>
  void get(const YAML::Node& node, const std::string& prefix, const char* key, T& out) {
    if (!node || !node.IsMap()) return;
    const YAML::Node v = node[key];
    if (!v) return;
    const std::string full = prefix + "." + key;
    try {
      if (!v.IsScalar()) throw YAML::Exception(v.Mark(), "not a scalar");
      out = v.as<T>();
    } catch (const YAML::Exception&) {
      std::string line = v.Mark().line >= 0 ? " (line " + std::to_string(v.Mark().line + 1) + ")" : "";
      error(full, "bad value" + line);
    }
  }

 private:
  std::string origin_;
  std::vector<std::string>& errors_;
};

}  // namespace

void validateDaemonConfig(const DaemonConfig& c, const std::string& origin,
                          std::vector<std::string>& errors) {
  auto err = [&](const std::string& key, const std::string& what) {
    errors.push_back(origin + ": daemon." + key + ": " + what);
  };
  if (c.processor != "odometry" && c.processor != "imu_dead_reckoning") {
    err("processor", "'" + c.processor + "' is not one of odometry, imu_dead_reckoning");
  }
  if (c.processor == "odometry" && c.camera.driver != "dataset" && c.calibration_dataset.empty()) {
    err("calibration_dataset", "required for processor odometry unless camera.driver is dataset");
  }
  if (c.camera.driver != "dataset" && c.camera.driver != "lcm") {
    err("camera.driver", "'" + c.camera.driver + "' is not one of dataset, lcm");
  }
  if (c.camera.driver == "dataset" && c.camera.dataset.empty()) {
    err("camera.dataset", "required when camera.driver is dataset");
  }
  if (!(c.camera.replay_speed >= 0.0) || c.camera.replay_speed > 1000.0) {
    err("camera.replay_speed", "must be in [0, 1000] (0 = as fast as possible)");
  }
  if (c.imu.driver != "dataset" && c.imu.driver != "lcm" && c.imu.driver != "serial" &&
      c.imu.driver != "none") {
    err("imu.driver", "'" + c.imu.driver + "' is not one of dataset, lcm, serial, none");
  }
  if (c.imu.driver == "dataset" && c.camera.driver != "dataset") {
    err("imu.driver", "dataset needs camera.driver dataset (the IMU comes from that folder)");
  }
  if (c.backpressure && (c.camera.driver != "dataset" || c.imu.driver == "serial")) {
    err("backpressure", "only for camera.driver dataset (file replay); live sources must never wait");
  }
  if (c.imu.driver == "serial" && c.imu.device.empty()) err("imu.device", "required for serial");
  if (c.imu.baud <= 0) err("imu.baud", "must be > 0");
  if (c.lcm.url.empty()) err("lcm.url", "must not be empty");
  for (auto [k, v] : {std::pair{"lcm.pose_channel", &c.lcm.pose_channel},
                      std::pair{"lcm.status_channel", &c.lcm.status_channel},
                      std::pair{"lcm.stereo_channel", &c.lcm.stereo_channel},
                      std::pair{"lcm.imu_channel", &c.lcm.imu_channel}}) {
    if (v->empty() || v->size() > 63) err(k, "must have 1 to 63 characters");
  }
  auto range = [&](const char* key, long long v, long long lo, long long hi) {
    if (v < lo || v > hi) {
      err(key, std::to_string(v) + " outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
  };
  range("rings.camera_frames", static_cast<long long>(c.rings.camera_frames), 2, 256);
  range("rings.imu_samples", static_cast<long long>(c.rings.imu_samples), 16, 1 << 20);
  range("rings.poses", static_cast<long long>(c.rings.poses), 2, 4096);
  range("threads.workers", c.worker_threads, 1, 16);
  range("watchdog_stall_ms", c.watchdog_stall_ms, 100, 600000);
  range("status_period_ms", c.status_period_ms, 100, 60000);
  range("imu_gap_ms", c.imu_gap_ms, 1, 10000);
  range("frame_gap_ms", c.frame_gap_ms, 1, 60000);
  range("imu_wait_ms", c.imu_wait_ms, 0, 1000);
  if (c.camera_imu_time_offset_ns < -1'000'000'000LL || c.camera_imu_time_offset_ns > 1'000'000'000LL) {
    err("camera_imu_time_offset_ns", "must be within +-1 s");
  }
}

DaemonConfigResult parseDaemonConfig(const std::string& yaml_text, const std::string& origin) {
  DaemonConfigResult res;
  DaemonConfig& c = res.config;
  Reader r(origin, res.errors);
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    res.errors.push_back(origin + ": line " + std::to_string(e.mark.line + 1) + ": YAML syntax: " + e.msg);
    return res;
  }
  if (!root || !root.IsMap() || !root["daemon"]) {
    res.errors.push_back(origin + ": daemon: section missing");
    return res;
  }
  const YAML::Node d = root["daemon"];
  r.onlyKeys(d, "daemon",
             {"processor", "calibration_dataset", "camera", "imu", "lcm", "rings", "threads", "watchdog_stall_ms", "status_period_ms",
              "camera_imu_time_offset_ns", "imu_gap_ms", "frame_gap_ms", "drain_to_newest",
              "backpressure", "imu_wait_ms"});
  if (!d.IsMap()) return res;

  r.get(d, "daemon", "processor", c.processor);
  r.get(d, "daemon", "calibration_dataset", c.calibration_dataset);

  const YAML::Node cam = d["camera"];
  r.onlyKeys(cam, "daemon.camera", {"driver", "dataset", "replay_speed"});
  r.get(cam, "daemon.camera", "driver", c.camera.driver);
  r.get(cam, "daemon.camera", "dataset", c.camera.dataset);
  r.get(cam, "daemon.camera", "replay_speed", c.camera.replay_speed);

  const YAML::Node imu = d["imu"];
  r.onlyKeys(imu, "daemon.imu", {"driver", "device", "baud"});
  r.get(imu, "daemon.imu", "driver", c.imu.driver);
  r.get(imu, "daemon.imu", "device", c.imu.device);
  r.get(imu, "daemon.imu", "baud", c.imu.baud);

  const YAML::Node lcm = d["lcm"];
  r.onlyKeys(lcm, "daemon.lcm", {"url", "pose_channel", "status_channel", "stereo_channel", "imu_channel"});
  r.get(lcm, "daemon.lcm", "url", c.lcm.url);
  r.get(lcm, "daemon.lcm", "pose_channel", c.lcm.pose_channel);
  r.get(lcm, "daemon.lcm", "status_channel", c.lcm.status_channel);
  r.get(lcm, "daemon.lcm", "stereo_channel", c.lcm.stereo_channel);
  r.get(lcm, "daemon.lcm", "imu_channel", c.lcm.imu_channel);

  const YAML::Node rings = d["rings"];
  r.onlyKeys(rings, "daemon.rings", {"camera_frames", "imu_samples", "poses"});
  long long cf = static_cast<long long>(c.rings.camera_frames);
  long long is = static_cast<long long>(c.rings.imu_samples);
  long long ps = static_cast<long long>(c.rings.poses);
  r.get(rings, "daemon.rings", "camera_frames", cf);
  r.get(rings, "daemon.rings", "imu_samples", is);
  r.get(rings, "daemon.rings", "poses", ps);
  // Negative values are kept out of size_t here and reported by validation.
  c.rings.camera_frames = static_cast<std::size_t>(std::max(0LL, cf));
  c.rings.imu_samples = static_cast<std::size_t>(std::max(0LL, is));
  c.rings.poses = static_cast<std::size_t>(std::max(0LL, ps));

  const YAML::Node th = d["threads"];
  r.onlyKeys(th, "daemon.threads", {"workers"});
  r.get(th, "daemon.threads", "workers", c.worker_threads);

  r.get(d, "daemon", "watchdog_stall_ms", c.watchdog_stall_ms);
  r.get(d, "daemon", "status_period_ms", c.status_period_ms);
  r.get(d, "daemon", "camera_imu_time_offset_ns", c.camera_imu_time_offset_ns);
  r.get(d, "daemon", "imu_gap_ms", c.imu_gap_ms);
  r.get(d, "daemon", "frame_gap_ms", c.frame_gap_ms);
  r.get(d, "daemon", "drain_to_newest", c.drain_to_newest);
  r.get(d, "daemon", "imu_wait_ms", c.imu_wait_ms);
  r.get(d, "daemon", "backpressure", c.backpressure);

  validateDaemonConfig(c, origin, res.errors);
  return res;
}

DaemonConfigResult loadDaemonConfig(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    DaemonConfigResult res;
    res.errors.push_back(path + ": cannot open file");
    return res;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return parseDaemonConfig(ss.str(), path);
}

std::string describe(const DaemonConfig& c) {
  std::ostringstream o;
  o << "daemon.processor = " << c.processor << "\n"
    << "daemon.calibration_dataset = " << c.calibration_dataset << "\n"
    << "daemon.camera.driver = " << c.camera.driver << "\n"
    << "daemon.camera.dataset = " << c.camera.dataset << "\n"
    << "daemon.camera.replay_speed = " << c.camera.replay_speed << "\n"
    << "daemon.imu.driver = " << c.imu.driver << "\n"
    << "daemon.imu.device = " << c.imu.device << "\n"
    << "daemon.imu.baud = " << c.imu.baud << "\n"
    << "daemon.lcm.url = " << c.lcm.url << "\n"
    << "daemon.lcm.pose_channel = " << c.lcm.pose_channel << "\n"
    << "daemon.lcm.status_channel = " << c.lcm.status_channel << "\n"
    << "daemon.lcm.stereo_channel = " << c.lcm.stereo_channel << "\n"
    << "daemon.lcm.imu_channel = " << c.lcm.imu_channel << "\n"
    << "daemon.rings.camera_frames = " << c.rings.camera_frames << "\n"
    << "daemon.rings.imu_samples = " << c.rings.imu_samples << "\n"
    << "daemon.rings.poses = " << c.rings.poses << "\n"
    << "daemon.threads.workers = " << c.worker_threads << "\n"
    << "daemon.watchdog_stall_ms = " << c.watchdog_stall_ms << "\n"
    << "daemon.status_period_ms = " << c.status_period_ms << "\n"
    << "daemon.camera_imu_time_offset_ns = " << c.camera_imu_time_offset_ns << "\n"
    << "daemon.imu_gap_ms = " << c.imu_gap_ms << "\n"
    << "daemon.frame_gap_ms = " << c.frame_gap_ms << "\n"
    << "daemon.drain_to_newest = " << (c.drain_to_newest ? "true" : "false") << "\n"
    << "daemon.backpressure = " << (c.backpressure ? "true" : "false") << "\n"
    << "daemon.imu_wait_ms = " << c.imu_wait_ms << "\n";
  return o.str();
}

}  // namespace seavio::daemon
