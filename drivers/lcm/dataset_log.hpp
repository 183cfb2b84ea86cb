#pragma once
/// Converts a loaded dataset (EuRoC/ASL, KITTI, simulator output) to an LCM log of raw
/// sensor messages, timestamps preserved (`seavio log`). Replaying the log with
/// lcm-logplayer into a daemon configured with camera/imu driver "lcm" feeds it the same data.
#include <cstdint>
#include <string>

#include "drivers/dataset/dataset.hpp"

namespace seavio::drivers {

struct DatasetLogOptions {
  std::string stereo_channel = "SEAVIO_STEREO";
  std::string imu_channel = "SEAVIO_IMU";
  std::string calibration_channel = "SEAVIO_CALIBRATION";
  bool include_imu = true;
};

struct DatasetLogStats {
  uint64_t frames = 0;
  uint64_t imu_samples = 0;
  std::string error;  ///< non-empty on failure, naming the file
  bool ok() const { return error.empty(); }
};

/// Writes the dataset's calibration (calibration_t, stamp order) first, then every frame
/// (stereo_t) and IMU sample (imu_t) of `ds` to `out_path` in time order; each event's log
/// time is the sample time [us] (the calibration's: the first sample's). Stops at the first unreadable image or
/// write error and says which.
DatasetLogStats writeDatasetLog(const Dataset& ds, const std::string& out_path,
                                const DatasetLogOptions& opt = {});

}  // namespace seavio::drivers
