#pragma once
/// A recorded sequence in memory: calibration, frame list (paths, images loaded lazily),
/// IMU samples and ground truth. Filled by the EuRoC/ASL and KITTI readers.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/camera/camera_model.hpp"
#include "core/common/types.hpp"
#include "core/imu/imu_noise.hpp"

namespace seavio::drivers {

/// Bad input: the message names the file and the line or key.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct FrameRef {
  int64_t t_ns = 0;
  std::string left_path, right_path;
};

struct GroundTruthState {
  int64_t t_ns = 0;
  Eigen::Isometry3d T_W_B = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();
  bool has_velocity = false;
};

struct Dataset {
  std::string root;
  std::string format;  ///< "euroc" or "kitti"
  camera::StereoCalibration calibration;
  imu::ImuNoise imu_noise;
  bool has_imu = false;
  std::vector<FrameRef> frames;
  std::vector<ImuSample> imu;                 ///< sorted, strictly increasing t_ns
  std::vector<GroundTruthState> ground_truth; ///< empty if the sequence has none
};

/// Reads an EuRoC/ASL folder (DIR or DIR/mav0). `kalibr_camchain`, when given, overrides
/// the folder's camera calibration. Throws InputError naming file and line/key.
Dataset loadEuroc(const std::string& dir, const std::optional<std::string>& kalibr_camchain = {});
/// Reads a KITTI odometry sequence folder (image_0, image_1, calib.txt, times.txt, and
/// poses/NN.txt next to it or inside it when present). Stereo only.
Dataset loadKitti(const std::string& dir);
/// Detects the layout and calls the right reader.
Dataset loadDataset(const std::string& dir, const std::optional<std::string>& kalibr_camchain = {});

/// Loads one frame's images as 8-bit grey; throws InputError if unreadable or of the
/// wrong size for the calibration.
StereoFrame loadFrame(const Dataset& ds, std::size_t index);

}  // namespace seavio::drivers
