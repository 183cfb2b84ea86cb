#include "daemon/source_factory.hpp"

#include "daemon/fault_counting_source.hpp"
#include "daemon/paced_source.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/dataset_source.hpp"
#include "drivers/imu_can/can_imu_source.hpp"
#include "drivers/imu_can/can_profile.hpp"
#include "drivers/imu_serial/serial_imu_source.hpp"
#include "drivers/lcm/lcm_sources.hpp"
#include "drivers/v4l2/v4l2_camera_source.hpp"
#ifdef SEAVIO_HAVE_ARAVIS
#include "drivers/aravis/aravis_camera_source.hpp"
#endif
#ifdef SEAVIO_HAVE_LIBCAMERA
#include "drivers/libcamera/libcamera_camera_source.hpp"
#endif

namespace seavio::daemon {

namespace {

/// The LCM provider the "lcm" sources read: a separate input (e.g. a log file) or the bus the
/// poses go out on.
const std::string& lcmInputUrl(const DaemonConfig& cfg) {
  return cfg.lcm.input_url.empty() ? cfg.lcm.url : cfg.lcm.input_url;
}

/// Camera drivers get the daemon's camera-to-IMU offset nowhere: the daemon adds
/// `camera_imu_time_offset_ns` to every frame itself, once for all drivers.
std::unique_ptr<drivers::CameraSource> makeLiveCamera(const DaemonConfig& cfg, std::string& error) {
  const CameraConfig& c = cfg.camera;
#ifdef SEAVIO_HAVE_ARAVIS
  if (c.driver == "aravis") {
    drivers::AravisCameraConfig a;
    a.left_id = c.aravis.left;
    a.right_id = c.aravis.right;
    a.width = c.width;
    a.height = c.height;
    a.exposure_us = c.aravis.exposure_us;
    a.frame_rate_hz = c.frame_rate_hz;
    a.trigger_source = c.aravis.trigger_source;
    a.n_buffers = c.buffers;
    a.packet_size = c.aravis.packet_size;
    a.socket_buffer_bytes = c.aravis.socket_buffer_bytes;
    a.pair_tolerance_ns = static_cast<int64_t>(c.aravis.pair_tolerance_ms * 1e6);
    a.reconnect_after_ms = c.aravis.reconnect_after_ms;
    a.clock.init_samples = c.aravis.clock_init_frames;
    a.clock.time_offset_ns = 0;
    return withFaultCounting(std::make_unique<drivers::AravisCameraSource>(a));
  }
#endif
#ifdef SEAVIO_HAVE_LIBCAMERA
  if (c.driver == "libcamera") {
    drivers::LibcameraConfig l;
    l.camera_id = c.libcamera.camera_id;
    l.width = c.width;
    l.height = c.height;
    l.n_buffers = c.buffers;
    l.time_offset_ns = 0;
    return withFaultCounting(std::make_unique<drivers::LibcameraCameraSource>(l));
  }
#endif
  if (c.driver == "v4l2") {
    drivers::V4l2CameraConfig v;
    v.device = c.v4l2.device;
    v.width = c.width;
    v.height = c.height;
    v.pixel_format = c.v4l2.pixel_format;
    v.frame_rate_hz = c.frame_rate_hz;
    v.n_buffers = c.buffers;
    v.clock.time_offset_ns = 0;
    return withFaultCounting(std::make_unique<drivers::V4l2CameraSource>(v));
  }
  error = "daemon.camera.driver: '" + c.driver + "' is not built into this seaviod";
  return nullptr;
}

}  // namespace

Sources makeSources(const DaemonConfig& cfg) {
  Sources out;
  std::shared_ptr<const drivers::Dataset> ds;
  if (cfg.camera.driver == "dataset") {
    try {
      ds = std::make_shared<const drivers::Dataset>(drivers::loadDataset(cfg.camera.dataset));
    } catch (const std::exception& e) {
      out.error = std::string("daemon.camera.dataset: ") + e.what();
      return out;
    }
    out.dataset = ds;
    auto clock = std::make_shared<ReplayClock>(cfg.camera.replay_speed);
    out.camera = std::make_unique<PacedCameraSource>(
        std::make_unique<drivers::DatasetCameraSource>(ds), clock);
    if (cfg.imu.driver == "dataset") {
      if (!ds->has_imu) {
        out.error = "daemon.imu.driver: dataset " + cfg.camera.dataset + " has no IMU data";
        return out;
      }
      out.imu = std::make_unique<PacedImuSource>(std::make_unique<drivers::DatasetImuSource>(ds), clock);
    }
  } else if (cfg.camera.driver == "lcm") {
    out.camera = std::make_unique<drivers::LcmStereoSource>(lcmInputUrl(cfg), cfg.lcm.stereo_channel,
                                                            cfg.rings.camera_frames);
  } else {
    out.camera = makeLiveCamera(cfg, out.error);
    if (!out.camera) return out;
  }
  if (cfg.imu.driver == "lcm") {
    out.imu = std::make_unique<drivers::LcmImuSource>(lcmInputUrl(cfg), cfg.lcm.imu_channel,
                                                      cfg.rings.imu_samples);
  } else if (cfg.imu.driver == "serial") {
    drivers::SerialImuConfig sc;
    sc.device = cfg.imu.device;
    sc.baud = cfg.imu.baud;
    sc.configure_rate_divisor = cfg.imu.rate_divisor;
    out.imu = withFaultCounting(std::make_unique<drivers::SerialImuSource>(sc));
  } else if (cfg.imu.driver == "can") {
    // The profile is a file: read and checked here, before any device is opened.
    std::string why;
    std::optional<drivers::CanProfile> profile = drivers::loadCanProfile(cfg.imu.can_profile, why);
    if (!profile) {
      out.error = "daemon.imu.can_profile: " + why;
      return out;
    }
    drivers::CanImuConfig cc;
    cc.profile = *profile;
    cc.interface = cfg.imu.interface;
    cc.candump_log = cfg.imu.candump_log;
    out.imu = withFaultCounting(std::make_unique<drivers::CanImuSource>(cc));
  }
  if (!out.camera) out.error = "daemon.camera.driver: '" + cfg.camera.driver + "' unknown";
  return out;
}

}  // namespace seavio::daemon
