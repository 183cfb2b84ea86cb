#include "drivers/lcm/calibration_msg.hpp"

#include <cmath>
#include <stdexcept>

#include "drivers/lcm/lcm_log_scanner.hpp"
#include "drivers/lcm/safe_decode.hpp"

namespace seavio::drivers {

namespace {

void putCamera(seavio_lcm::calibration_t& m, int i, const camera::CameraIntrinsics& k, const Eigen::Isometry3d& T) {
  m.width[i] = k.width;
  m.height[i] = k.height;
  m.fx[i] = k.fx;
  m.fy[i] = k.fy;
  m.cx[i] = k.cx;
  m.cy[i] = k.cy;
  m.distortion_model[i] = camera::toString(k.model);
  for (int j = 0; j < 4; ++j) m.distortion[i][j] = k.distortion[static_cast<std::size_t>(j)];
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m.T_B_C[i][4 * r + c] = T.matrix()(r, c);
}

bool getCamera(const seavio_lcm::calibration_t& m, int i, camera::CameraIntrinsics& k, Eigen::Isometry3d& T,
               std::string& error) {
  const std::string cam = "cam" + std::to_string(i);
  k.width = m.width[i];
  k.height = m.height[i];
  k.fx = m.fx[i];
  k.fy = m.fy[i];
  k.cx = m.cx[i];
  k.cy = m.cy[i];
  if (k.width <= 0 || k.height <= 0) {
    error = cam + ": image size " + std::to_string(k.width) + " x " + std::to_string(k.height) + " is not positive";
    return false;
  }
  if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy) && k.fx > 0 &&
        k.fy > 0)) {
    error = cam + ": focal lengths must be finite and > 0, principal point finite";
    return false;
  }
  const std::optional<camera::DistortionModel> model = camera::parseDistortionModel(m.distortion_model[i]);
  if (!model) {
    error = cam + ": unknown distortion model '" + std::string(m.distortion_model[i]) + "' (expected " +
            camera::kDistortionModelNames + ")";
    return false;
  }
  k.model = *model;
  for (int j = 0; j < 4; ++j) k.distortion[static_cast<std::size_t>(j)] = m.distortion[i][j];
  T.matrix().setIdentity();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = m.T_B_C[i][4 * r + c];
  if (!T.matrix().allFinite()) {
    error = cam + ": T_B_C is not finite";
    return false;
  }
  return true;
}

}  // namespace

seavio_lcm::calibration_t toCalibrationMsg(const LogCalibration& c) {
  seavio_lcm::calibration_t m{};
  m.version = seavio_lcm::calibration_t::VERSION;
  putCamera(m, 0, c.stereo.cam0, c.stereo.T_B_C0);
  putCamera(m, 1, c.stereo.cam1, c.stereo.T_B_C1);
  m.gyroscope_noise_density = c.imu_noise.gyroscope_noise_density;
  m.gyroscope_random_walk = c.imu_noise.gyroscope_random_walk;
  m.accelerometer_noise_density = c.imu_noise.accelerometer_noise_density;
  m.accelerometer_random_walk = c.imu_noise.accelerometer_random_walk;
  m.imu_rate_hz = c.imu_noise.rate_hz;
  m.imu_order = c.consumed_order ? seavio_lcm::calibration_t::IMU_ORDER_CONSUMED : seavio_lcm::calibration_t::IMU_ORDER_TIME;
  return m;
}

std::optional<LogCalibration> fromCalibrationMsg(const seavio_lcm::calibration_t& m, std::string* error) {
  LogCalibration c;
  std::string why;
  if (!getCamera(m, 0, c.stereo.cam0, c.stereo.T_B_C0, why) || !getCamera(m, 1, c.stereo.cam1, c.stereo.T_B_C1, why)) {
    if (error) *error = why;
    return std::nullopt;
  }
  c.imu_noise.gyroscope_noise_density = m.gyroscope_noise_density;
  c.imu_noise.gyroscope_random_walk = m.gyroscope_random_walk;
  c.imu_noise.accelerometer_noise_density = m.accelerometer_noise_density;
  c.imu_noise.accelerometer_random_walk = m.accelerometer_random_walk;
  c.imu_noise.rate_hz = m.imu_rate_hz;
  if (m.imu_order != seavio_lcm::calibration_t::IMU_ORDER_TIME &&
      m.imu_order != seavio_lcm::calibration_t::IMU_ORDER_CONSUMED) {
    if (error) *error = "imu_order " + std::to_string(m.imu_order) + " is neither TIME (0) nor CONSUMED (1)";
    return std::nullopt;
  }
  c.consumed_order = m.imu_order == seavio_lcm::calibration_t::IMU_ORDER_CONSUMED;
  return c;
}

std::optional<LogCalibration> readLogCalibration(const std::string& path, const std::string& channel,
                                                 std::string* error) {
  LcmLogScanner scan(path);
  if (!scan.good()) {
    if (error) *error = scan.error();
    return std::nullopt;
  }
  const auto want = [&channel](const std::string& ch) { return ch == channel; };
  while (std::optional<ScannedEvent> ev = scan.next(want)) {
    if (ev->channel != channel) continue;
    seavio_lcm::calibration_t m{};
    if (!decodeLcm(m, ev->data.data(), ev->data.size())) {
      if (error) *error = path + ": byte offset " + std::to_string(ev->offset) + ": the " + channel +
                          " message does not decode (other type or version, or damaged)";
      return std::nullopt;
    }
    std::string why;
    std::optional<LogCalibration> c = fromCalibrationMsg(m, &why);
    if (!c && error) *error = path + ": byte offset " + std::to_string(ev->offset) + ": " + channel + ": " + why;
    return c;
  }
  if (error) *error = path + ": no " + channel + " message (a log written before logs carried their calibration?)";
  return std::nullopt;
}

}  // namespace seavio::drivers
