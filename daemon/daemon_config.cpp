#include "daemon/daemon_config.hpp"

#include "daemon/cpu_list.hpp"

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
      // A list or map as key has no name to report ("daemon.: unknown key"): say where.
      if (!kv.first.IsScalar()) {
        error(prefix, "a key must be a plain name (line " + std::to_string(kv.first.Mark().line + 1) + ")");
        continue;
      }
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

std::string cpuList(const std::vector<int>& cpus) {
  std::string s;
  for (int c : cpus) {
    if (!s.empty()) s += ',';
    s += std::to_string(c);
  }
  return s.empty() ? "any" : s;
}

}  // namespace

std::string cameraDriversBuilt() {
  std::string s = "dataset, lcm, ";
#ifdef SEAVIO_HAVE_ARAVIS
  s += "aravis, ";
#endif
  s += "v4l2, ";
#ifdef SEAVIO_HAVE_LIBCAMERA
  s += "libcamera, ";
#endif
  return s.substr(0, s.size() - 1);  // "a, b," : the validator looks names up as " name,"
}

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
  const std::string cam_drivers = cameraDriversBuilt();
  if ((" " + cam_drivers + ",").find(" " + c.camera.driver + ",") == std::string::npos) {
    err("camera.driver", "'" + c.camera.driver + "' is not one of " + cam_drivers.substr(0, cam_drivers.size() - 1) +
                             (c.camera.driver == "libcamera" || c.camera.driver == "aravis"
                                  ? " (" + c.camera.driver + " support was not built in)"
                                  : ""));
  }
  const std::string& cd = c.camera.driver;
  const bool live_cam = cd == "aravis" || cd == "v4l2" || cd == "libcamera";
  if (live_cam) {
    if (!(c.camera.frame_rate_hz >= 0.0) || c.camera.frame_rate_hz > 1000.0) err("camera.frame_rate_hz", "must be in [0, 1000]");
    if (c.camera.buffers < 2 || c.camera.buffers > 64) err("camera.buffers", std::to_string(c.camera.buffers) + " outside [2, 64]");
    if (c.camera.width < 0 || c.camera.width > 16384) err("camera.width", "must be in [0, 16384]");
    if (c.camera.height < 0 || c.camera.height > 16384) err("camera.height", "must be in [0, 16384]");
    if (c.camera.width > 0 && c.camera.height == 0) err("camera.height", "must be set together with camera.width");
  }
  if (cd == "v4l2" || cd == "libcamera" || (cd == "aravis" && c.camera.aravis.right.empty())) {
    // Side by side: both views share one image, so its width splits in two.
    if (c.camera.width % 2 != 0) err("camera.width", "side-by-side stereo needs an even width");
  }
  if (cd == "v4l2" || cd == "libcamera") {
    if (c.camera.width <= 0) err("camera.width", "required (> 0) for " + cd);
    if (c.camera.height <= 0) err("camera.height", "required (> 0) for " + cd);
  }
  if (cd == "aravis") {
    const AravisSection& a = c.camera.aravis;
    if (a.left.empty()) err("camera.aravis.left", "required for camera.driver aravis");
    if (!a.right.empty() && a.right == a.left) err("camera.aravis.right", "must differ from camera.aravis.left");
    if (!(a.exposure_us >= 0.0) || a.exposure_us > 10'000'000.0) err("camera.aravis.exposure_us", "must be in [0, 1e7]");
    if (a.packet_size != 0 && (a.packet_size < 576 || a.packet_size > 16384))
      err("camera.aravis.packet_size", "must be 0 or in [576, 16384]");
    if (a.socket_buffer_bytes < 0 || a.socket_buffer_bytes > (1 << 28))
      err("camera.aravis.socket_buffer_bytes", "must be in [0, 268435456]");
    if (!(a.pair_tolerance_ms > 0.0) || a.pair_tolerance_ms > 1000.0)
      err("camera.aravis.pair_tolerance_ms", "must be in (0, 1000]");
    else if (c.camera.frame_rate_hz > 0 && a.pair_tolerance_ms * 2.0 >= 1000.0 / c.camera.frame_rate_hz)
      // Wider than half a period, a frame could pair with its neighbour's partner.
      err("camera.aravis.pair_tolerance_ms", "must be below half the frame period (" +
                                                 std::to_string(500.0 / c.camera.frame_rate_hz) + " ms)");
    if (a.reconnect_after_ms < 100 || a.reconnect_after_ms > 600000)
      err("camera.aravis.reconnect_after_ms", "must be in [100, 600000]");
    if (a.clock_init_frames < 1 || a.clock_init_frames > 1000) err("camera.aravis.clock_init_frames", "must be in [1, 1000]");
  }
  if (cd == "v4l2") {
    if (c.camera.v4l2.device.empty()) err("camera.v4l2.device", "required for camera.driver v4l2");
    if (c.camera.v4l2.pixel_format != "GREY" && c.camera.v4l2.pixel_format != "YUYV")
      err("camera.v4l2.pixel_format", "'" + c.camera.v4l2.pixel_format + "' is not one of GREY, YUYV");
  }
  if (c.camera.driver == "dataset" && c.camera.dataset.empty()) {
    err("camera.dataset", "required when camera.driver is dataset");
  }
  if (!(c.camera.replay_speed >= 0.0) || c.camera.replay_speed > 1000.0) {
    err("camera.replay_speed", "must be in [0, 1000] (0 = as fast as possible)");
  }
  if (c.imu.driver != "dataset" && c.imu.driver != "lcm" && c.imu.driver != "serial" && c.imu.driver != "can" &&
      c.imu.driver != "none") {
    err("imu.driver", "'" + c.imu.driver + "' is not one of dataset, lcm, serial, can, none");
  }
  if (c.imu.driver == "serial" && (c.imu.rate_divisor < 0 || c.imu.rate_divisor > 800))
    err("imu.rate_divisor", "must be in [0, 800]");
  if (c.imu.driver == "can") {
    if (c.imu.can_profile.empty()) err("imu.can_profile", "required for imu.driver can");
    if (c.imu.candump_log.empty() && (c.imu.interface.empty() || c.imu.interface.size() >= 16))
      err("imu.interface", "must have 1 to 15 characters (IFNAMSIZ)");
  }
  if (c.imu.driver == "dataset" && c.camera.driver != "dataset") {
    err("imu.driver", "dataset needs camera.driver dataset (the IMU comes from that folder)");
  }
  const bool lcm_file = c.camera.driver == "lcm" && c.lcm.input_url.rfind("file://", 0) == 0;
  if (c.backpressure && ((c.camera.driver != "dataset" && !lcm_file) || c.imu.driver == "serial" || c.imu.driver == "can")) {
    err("backpressure", "only for file replay (camera.driver dataset, or lcm with a file:// lcm.input_url); "
                        "live sources must never wait");
  }
  if (c.record.enabled()) {
    if (c.processor != "odometry") err("record.path", "recording needs processor odometry (its calibration goes in the log)");
    if (!(c.record.max_file_mb >= 1.0) || c.record.max_file_mb > 1e6) err("record.max_file_mb", "must be in [1, 1e6]");
    if (c.record.max_files < 1 || c.record.max_files > 100000) err("record.max_files", "must be in [1, 100000]");
    if (c.record.ring_frames < 1 || c.record.ring_frames > 1024) err("record.ring_frames", "must be in [1, 1024]");
    if (c.record.ring_items < c.record.ring_frames + 1 || c.record.ring_items > (1u << 20))
      err("record.ring_items", "must be in [ring_frames + 1, 1048576]");
  }
  if (c.imu.dead_policy != "flag" && c.imu.dead_policy != "exit")
    err("imu.dead_policy", "'" + c.imu.dead_policy + "' is not one of flag, exit");
  if (c.imu.dead_after_ms < 100 || c.imu.dead_after_ms > 600000)
    err("imu.dead_after_ms", std::to_string(c.imu.dead_after_ms) + " outside [100, 600000]");
  if (c.imu.driver == "serial" && c.imu.device.empty()) err("imu.device", "required for serial");
  if (c.imu.baud <= 0) err("imu.baud", "must be > 0");
  if (c.lcm.url.empty()) err("lcm.url", "must not be empty");
  if (!c.lcm.input_url.empty() && c.camera.driver != "lcm" && c.imu.driver != "lcm") {
    err("lcm.input_url", "only read by camera.driver or imu.driver lcm");
  }
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
  range("rings.global_requests", static_cast<long long>(c.rings.global_requests), 1, 256);
  range("threads.workers", c.worker_threads, 1, 16);
  range("watchdog_stall_ms", c.watchdog_stall_ms, 100, 600000);
  range("status_period_ms", c.status_period_ms, 100, 60000);
  range("imu_gap_ms", c.imu_gap_ms, 1, 10000);
  range("frame_gap_ms", c.frame_gap_ms, 1, 60000);
  range("imu_wait_ms", c.imu_wait_ms, 0, 1000);
  range("imu_hold_ms", c.imu_hold_ms, 0, 100);
  // 99 is left to the kernel's own real-time threads (watchdog, migration).
  range("realtime.priority", c.realtime.priority, 0, 98);
  range("realtime.background_nice", c.realtime.background_nice, 0, 19);
  range("deadline.frame_budget_ms", c.deadline.frame_budget_ms, 1, 10000);
  range("deadline.window_frames", c.deadline.window_frames, 5, 1000);
  if (!(c.deadline.release_fraction > 0.0) || !(c.deadline.release_fraction < 1.0))
    err("deadline.release_fraction", "must be in (0, 1)");
  if (!(c.deadline.feature_fraction > 0.0) || !(c.deadline.feature_fraction < 1.0))
    err("deadline.feature_fraction", "must be in (0, 1)");
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
              "backpressure", "imu_wait_ms", "imu_hold_ms", "global_thread", "realtime", "record",
              "deadline"});
  if (!d.IsMap()) return res;

  r.get(d, "daemon", "processor", c.processor);
  r.get(d, "daemon", "calibration_dataset", c.calibration_dataset);

  const YAML::Node cam = d["camera"];
  r.onlyKeys(cam, "daemon.camera",
             {"driver", "dataset", "replay_speed", "width", "height", "frame_rate_hz", "buffers", "aravis", "v4l2",
              "libcamera"});
  r.get(cam, "daemon.camera", "driver", c.camera.driver);
  r.get(cam, "daemon.camera", "dataset", c.camera.dataset);
  r.get(cam, "daemon.camera", "replay_speed", c.camera.replay_speed);
  r.get(cam, "daemon.camera", "width", c.camera.width);
  r.get(cam, "daemon.camera", "height", c.camera.height);
  r.get(cam, "daemon.camera", "frame_rate_hz", c.camera.frame_rate_hz);
  r.get(cam, "daemon.camera", "buffers", c.camera.buffers);
  if (cam && cam.IsMap()) {
    const YAML::Node av = cam["aravis"];
    const char* ap = "daemon.camera.aravis";
    r.onlyKeys(av, ap,
               {"left", "right", "exposure_us", "trigger_source", "packet_size", "socket_buffer_bytes",
                "pair_tolerance_ms", "reconnect_after_ms", "clock_init_frames"});
    AravisSection& a = c.camera.aravis;
    r.get(av, ap, "left", a.left);
    r.get(av, ap, "right", a.right);
    r.get(av, ap, "exposure_us", a.exposure_us);
    r.get(av, ap, "trigger_source", a.trigger_source);
    r.get(av, ap, "packet_size", a.packet_size);
    r.get(av, ap, "socket_buffer_bytes", a.socket_buffer_bytes);
    r.get(av, ap, "pair_tolerance_ms", a.pair_tolerance_ms);
    r.get(av, ap, "reconnect_after_ms", a.reconnect_after_ms);
    r.get(av, ap, "clock_init_frames", a.clock_init_frames);
    const YAML::Node v4 = cam["v4l2"];
    r.onlyKeys(v4, "daemon.camera.v4l2", {"device", "pixel_format"});
    r.get(v4, "daemon.camera.v4l2", "device", c.camera.v4l2.device);
    r.get(v4, "daemon.camera.v4l2", "pixel_format", c.camera.v4l2.pixel_format);
    const YAML::Node lc = cam["libcamera"];
    r.onlyKeys(lc, "daemon.camera.libcamera", {"camera_id"});
    r.get(lc, "daemon.camera.libcamera", "camera_id", c.camera.libcamera.camera_id);
  }

  const YAML::Node imu = d["imu"];
  r.onlyKeys(imu, "daemon.imu",
             {"driver", "device", "baud", "rate_divisor", "interface", "can_profile", "candump_log", "dead_after_ms",
              "dead_policy"});
  r.get(imu, "daemon.imu", "driver", c.imu.driver);
  r.get(imu, "daemon.imu", "device", c.imu.device);
  r.get(imu, "daemon.imu", "baud", c.imu.baud);
  r.get(imu, "daemon.imu", "rate_divisor", c.imu.rate_divisor);
  r.get(imu, "daemon.imu", "interface", c.imu.interface);
  r.get(imu, "daemon.imu", "can_profile", c.imu.can_profile);
  r.get(imu, "daemon.imu", "candump_log", c.imu.candump_log);
  r.get(imu, "daemon.imu", "dead_after_ms", c.imu.dead_after_ms);
  r.get(imu, "daemon.imu", "dead_policy", c.imu.dead_policy);

  const YAML::Node lcm = d["lcm"];
  r.onlyKeys(lcm, "daemon.lcm", {"url", "input_url", "pose_channel", "status_channel", "stereo_channel", "imu_channel"});
  r.get(lcm, "daemon.lcm", "url", c.lcm.url);
  r.get(lcm, "daemon.lcm", "input_url", c.lcm.input_url);
  r.get(lcm, "daemon.lcm", "pose_channel", c.lcm.pose_channel);
  r.get(lcm, "daemon.lcm", "status_channel", c.lcm.status_channel);
  r.get(lcm, "daemon.lcm", "stereo_channel", c.lcm.stereo_channel);
  r.get(lcm, "daemon.lcm", "imu_channel", c.lcm.imu_channel);

  const YAML::Node rings = d["rings"];
  r.onlyKeys(rings, "daemon.rings", {"camera_frames", "imu_samples", "poses", "global_requests"});
  long long cf = static_cast<long long>(c.rings.camera_frames);
  long long is = static_cast<long long>(c.rings.imu_samples);
  long long ps = static_cast<long long>(c.rings.poses);
  long long gr = static_cast<long long>(c.rings.global_requests);
  r.get(rings, "daemon.rings", "camera_frames", cf);
  r.get(rings, "daemon.rings", "imu_samples", is);
  r.get(rings, "daemon.rings", "poses", ps);
  r.get(rings, "daemon.rings", "global_requests", gr);
  // Negative values are kept out of size_t here and reported by validation.
  c.rings.camera_frames = static_cast<std::size_t>(std::max(0LL, cf));
  c.rings.imu_samples = static_cast<std::size_t>(std::max(0LL, is));
  c.rings.poses = static_cast<std::size_t>(std::max(0LL, ps));
  c.rings.global_requests = static_cast<std::size_t>(std::max(0LL, gr));

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
  r.get(d, "daemon", "imu_hold_ms", c.imu_hold_ms);
  r.get(d, "daemon", "backpressure", c.backpressure);
  r.get(d, "daemon", "global_thread", c.global_thread);

  const YAML::Node rt = d["realtime"];
  r.onlyKeys(rt, "daemon.realtime", {"priority", "background_nice", "lock_memory", "frame_cpus", "background_cpus"});
  r.get(rt, "daemon.realtime", "priority", c.realtime.priority);
  r.get(rt, "daemon.realtime", "background_nice", c.realtime.background_nice);
  r.get(rt, "daemon.realtime", "lock_memory", c.realtime.lock_memory);
  for (auto [key, cpus] : {std::pair{"frame_cpus", &c.realtime.frame_cpus},
                           std::pair{"background_cpus", &c.realtime.background_cpus}}) {
    std::string text;
    r.get(rt, "daemon.realtime", key, text);
    std::string why;
    if (!text.empty() && !parseCpuList(text, *cpus, why)) r.error(std::string("daemon.realtime.") + key, why);
  }

  const YAML::Node dl = d["deadline"];
  r.onlyKeys(dl, "daemon.deadline",
             {"frame_budget_ms", "window_frames", "release_fraction", "feature_fraction", "degrade"});
  r.get(dl, "daemon.deadline", "frame_budget_ms", c.deadline.frame_budget_ms);
  r.get(dl, "daemon.deadline", "window_frames", c.deadline.window_frames);
  r.get(dl, "daemon.deadline", "release_fraction", c.deadline.release_fraction);
  r.get(dl, "daemon.deadline", "feature_fraction", c.deadline.feature_fraction);
  r.get(dl, "daemon.deadline", "degrade", c.deadline.degrade);

  const YAML::Node rec = d["record"];
  r.onlyKeys(rec, "daemon.record", {"path", "max_file_mb", "max_files", "ring_items", "ring_frames"});
  r.get(rec, "daemon.record", "path", c.record.path);
  r.get(rec, "daemon.record", "max_file_mb", c.record.max_file_mb);
  r.get(rec, "daemon.record", "max_files", c.record.max_files);
  long long ri = static_cast<long long>(c.record.ring_items), rf = static_cast<long long>(c.record.ring_frames);
  r.get(rec, "daemon.record", "ring_items", ri);
  r.get(rec, "daemon.record", "ring_frames", rf);
  c.record.ring_items = static_cast<std::size_t>(std::max(0LL, ri));
  c.record.ring_frames = static_cast<std::size_t>(std::max(0LL, rf));

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
    << "daemon.camera.width = " << c.camera.width << "\n"
    << "daemon.camera.height = " << c.camera.height << "\n"
    << "daemon.camera.frame_rate_hz = " << c.camera.frame_rate_hz << "\n"
    << "daemon.camera.buffers = " << c.camera.buffers << "\n"
    << "daemon.camera.aravis.left = " << c.camera.aravis.left << "\n"
    << "daemon.camera.aravis.right = " << c.camera.aravis.right << "\n"
    << "daemon.camera.aravis.exposure_us = " << c.camera.aravis.exposure_us << "\n"
    << "daemon.camera.aravis.trigger_source = " << c.camera.aravis.trigger_source << "\n"
    << "daemon.camera.aravis.packet_size = " << c.camera.aravis.packet_size << "\n"
    << "daemon.camera.aravis.socket_buffer_bytes = " << c.camera.aravis.socket_buffer_bytes << "\n"
    << "daemon.camera.aravis.pair_tolerance_ms = " << c.camera.aravis.pair_tolerance_ms << "\n"
    << "daemon.camera.aravis.reconnect_after_ms = " << c.camera.aravis.reconnect_after_ms << "\n"
    << "daemon.camera.aravis.clock_init_frames = " << c.camera.aravis.clock_init_frames << "\n"
    << "daemon.camera.v4l2.device = " << c.camera.v4l2.device << "\n"
    << "daemon.camera.v4l2.pixel_format = " << c.camera.v4l2.pixel_format << "\n"
    << "daemon.camera.libcamera.camera_id = " << c.camera.libcamera.camera_id << "\n"
    << "daemon.imu.driver = " << c.imu.driver << "\n"
    << "daemon.imu.device = " << c.imu.device << "\n"
    << "daemon.imu.baud = " << c.imu.baud << "\n"
    << "daemon.imu.rate_divisor = " << c.imu.rate_divisor << "\n"
    << "daemon.imu.interface = " << c.imu.interface << "\n"
    << "daemon.imu.can_profile = " << c.imu.can_profile << "\n"
    << "daemon.imu.candump_log = " << c.imu.candump_log << "\n"
    << "daemon.imu.dead_after_ms = " << c.imu.dead_after_ms << "\n"
    << "daemon.imu.dead_policy = " << c.imu.dead_policy << "\n"
    << "daemon.lcm.url = " << c.lcm.url << "\n"
    << "daemon.lcm.input_url = " << c.lcm.input_url << "\n"
    << "daemon.lcm.pose_channel = " << c.lcm.pose_channel << "\n"
    << "daemon.lcm.status_channel = " << c.lcm.status_channel << "\n"
    << "daemon.lcm.stereo_channel = " << c.lcm.stereo_channel << "\n"
    << "daemon.lcm.imu_channel = " << c.lcm.imu_channel << "\n"
    << "daemon.rings.camera_frames = " << c.rings.camera_frames << "\n"
    << "daemon.rings.imu_samples = " << c.rings.imu_samples << "\n"
    << "daemon.rings.poses = " << c.rings.poses << "\n"
    << "daemon.rings.global_requests = " << c.rings.global_requests << "\n"
    << "daemon.threads.workers = " << c.worker_threads << "\n"
    << "daemon.watchdog_stall_ms = " << c.watchdog_stall_ms << "\n"
    << "daemon.status_period_ms = " << c.status_period_ms << "\n"
    << "daemon.camera_imu_time_offset_ns = " << c.camera_imu_time_offset_ns << "\n"
    << "daemon.imu_gap_ms = " << c.imu_gap_ms << "\n"
    << "daemon.frame_gap_ms = " << c.frame_gap_ms << "\n"
    << "daemon.drain_to_newest = " << (c.drain_to_newest ? "true" : "false") << "\n"
    << "daemon.backpressure = " << (c.backpressure ? "true" : "false") << "\n"
    << "daemon.imu_wait_ms = " << c.imu_wait_ms << "\n"
    << "daemon.imu_hold_ms = " << c.imu_hold_ms << "\n"
    << "daemon.global_thread = " << (c.global_thread ? "true" : "false") << "\n"
    << "daemon.realtime.priority = " << c.realtime.priority << "\n"
    << "daemon.realtime.background_nice = " << c.realtime.background_nice << "\n"
    << "daemon.realtime.lock_memory = " << (c.realtime.lock_memory ? "true" : "false") << "\n"
    << "daemon.record.path = " << c.record.path << "\n"
    << "daemon.record.max_file_mb = " << c.record.max_file_mb << "\n"
    << "daemon.record.max_files = " << c.record.max_files << "\n"
    << "daemon.record.ring_items = " << c.record.ring_items << "\n"
    << "daemon.record.ring_frames = " << c.record.ring_frames << "\n"
    << "daemon.realtime.frame_cpus = " << cpuList(c.realtime.frame_cpus) << "\n"
    << "daemon.realtime.background_cpus = " << cpuList(c.realtime.background_cpus) << "\n"
    << "daemon.deadline.frame_budget_ms = " << c.deadline.frame_budget_ms << "\n"
    << "daemon.deadline.window_frames = " << c.deadline.window_frames << "\n"
    << "daemon.deadline.release_fraction = " << c.deadline.release_fraction << "\n"
    << "daemon.deadline.feature_fraction = " << c.deadline.feature_fraction << "\n"
    << "daemon.deadline.degrade = " << (c.deadline.degrade ? "true" : "false") << "\n";
  return o.str();
}

}  // namespace seavio::daemon
