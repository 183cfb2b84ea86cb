#pragma once
/// Builds the camera and IMU sources named in the config (no device is touched here: the
/// daemon opens them in start()).
#include <memory>
#include <string>

#include "daemon/daemon_config.hpp"
#include "drivers/dataset/dataset.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::daemon {

struct Sources {
  std::unique_ptr<drivers::CameraSource> camera;
  std::unique_ptr<drivers::ImuSource> imu;  ///< null for imu.driver "none"
  std::shared_ptr<const drivers::Dataset> dataset;  ///< camera dataset (driver "dataset")
  std::string error;                        ///< non-empty: could not build (file named)
};

/// Loads dataset indexes (files only, no devices) and wraps replayed sources in pacing.
Sources makeSources(const DaemonConfig& cfg);

}  // namespace seavio::daemon
