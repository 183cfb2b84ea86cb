#include "daemon/source_factory.hpp"

#include "daemon/paced_source.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/dataset/dataset_source.hpp"
#include "drivers/imu_serial/serial_imu_source.hpp"
#include "drivers/lcm/lcm_sources.hpp"

namespace seavio::daemon {

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
    out.camera = std::make_unique<drivers::LcmStereoSource>(cfg.lcm.url, cfg.lcm.stereo_channel,
                                                            cfg.rings.camera_frames);
  }
  if (cfg.imu.driver == "lcm") {
    out.imu = std::make_unique<drivers::LcmImuSource>(cfg.lcm.url, cfg.lcm.imu_channel,
                                                      cfg.rings.imu_samples);
  } else if (cfg.imu.driver == "serial") {
    drivers::SerialImuConfig sc;
    sc.device = cfg.imu.device;
    sc.baud = cfg.imu.baud;
    out.imu = std::make_unique<drivers::SerialImuSource>(sc);
  }
  if (!out.camera) out.error = "daemon.camera.driver: '" + cfg.camera.driver + "' unknown";
  return out;
}

}  // namespace seavio::daemon
