#pragma once
/// Writes a simulated sequence in the EuRoC/ASL layout that `seavio run` reads:
/// DIR/mav0/{cam0,cam1}/{data.csv,data/<t_ns>.png,sensor.yaml}, imu0/{data.csv,sensor.yaml},
/// state_groundtruth_estimate0/data.csv (body pose, velocity and biases in W at IMU rate).
#include <cstddef>
#include <functional>
#include <string>

#include "tools/simulate/sim_config.hpp"
#include "tools/simulate/stereo_rig_model.hpp"

namespace seavio::simulate {

/// Called after each rendered frame with (frames done, frames total).
using ProgressFn = std::function<void(std::size_t done, std::size_t total)>;

/// Summary of a written sequence.
struct SequenceStats {
  std::size_t frames = 0;
  std::size_t imu_samples = 0;
  double path_length_m = 0;
  double mean_snow_visible = 0;  ///< per image
};

/// Validates `config`, refuses to touch an existing dataset in `out_dir` unless `force`
/// (then replaces DIR/mav0 only), renders and writes everything. Throws std::invalid_argument
/// for bad parameters and std::runtime_error naming the path for file-system problems.
SequenceStats writeSequence(const SimConfig& config, const std::string& out_dir, bool force,
                            const ProgressFn& progress = {});

/// EuRoC camera sensor.yaml text for camera `cam` of `rig`.
std::string cameraSensorYaml(const StereoRigModel& rig, int cam, double rate_hz);
/// EuRoC IMU sensor.yaml text.
std::string imuSensorYaml(const imu::ImuNoise& noise);

}  // namespace seavio::simulate
