#pragma once
/// `ImuSource` for a VectorNav VN-100/VN-200 on a serial port (binary output, group 1).
#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <string>

#include "drivers/imu_serial/device_clock.hpp"
#include "drivers/imu_serial/serial_port.hpp"
#include "drivers/imu_serial/vectornav_parser.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

struct SerialImuConfig {
  std::string device = "/dev/ttyUSB0";
  int baud = 921600;  ///< [bit/s]
  /// If > 0, `start()` writes Binary Output Register 1 with this divisor of 800 Hz
  /// (UM001, "Binary Output Register 1", register 75); 0 leaves the sensor's stored configuration alone.
  int configure_rate_divisor = 0;
  int vn_port = 1;          ///< sensor serial port the output goes to (1 or 2)
  DeviceClockConfig clock;  ///< offset estimation and camera-to-IMU offset
  /// After the port fails (a USB adapter unplugged), reopen `device` this often [ms]
  /// instead of reporting kError; 0 reports kError and stays closed.
  int reopen_interval_ms = 500;
};

/// Faults seen by the serial IMU; each is also logged with spdlog.
struct SerialImuFaults {
  uint64_t checksum_errors = 0;
  uint64_t garbage_bytes = 0;
  uint64_t partial_packets = 0;  ///< reads that ended inside a packet (completed later)
  uint64_t unsupported_packets = 0;
  uint64_t timestamp_jumps = 0;
  uint64_t read_errors = 0;
  uint64_t reconnects = 0;  ///< successful reopenings after a port failure
};

class SerialImuSource final : public ImuSource {
 public:
  explicit SerialImuSource(SerialImuConfig cfg);
  bool start() override;
  /// Next sample; kTimeout if none within `timeout` (also while reopening a failed port),
  /// kError if the port failed and `reopen_interval_ms` is 0.
  ReadStatus read(ImuSample& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override { return "vectornav:" + cfg_.device; }
  const SerialImuFaults& faults() const { return faults_; }

 private:
  void drain(int64_t host_ns);
  bool open();
  std::chrono::steady_clock::time_point next_reopen_{};
  void updateFaults();
  SerialImuConfig cfg_;
  SerialPort port_;
  VectorNavParser parser_;
  DeviceClock clock_;
  std::deque<ImuSample> ready_;
  std::array<uint8_t, 4096> chunk_{};
  SerialImuFaults faults_;
  VectorNavParserStats seen_;  ///< parser counters already folded into faults_
  std::string error_;
};

}  // namespace seavio::drivers
