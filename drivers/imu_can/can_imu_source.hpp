#pragma once
/// `ImuSource` for an IMU on CAN: a SocketCAN raw socket on a named interface, any
/// already-open fd that carries whole `struct can_frame`s (tests use a SOCK_SEQPACKET
/// socketpair), or a candump log replayed as fast as it is read.
#include <chrono>
#include <deque>
#include <string>

#include "drivers/imu_can/can_imu_decoder.hpp"
#include "drivers/imu_can/candump_reader.hpp"
#include "drivers/imu_serial/device_clock.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

struct CanImuConfig {
  CanProfile profile;
  std::string interface;    ///< SocketCAN interface, e.g. "can0" (used if `fd` < 0 and no log)
  int fd = -1;              ///< an open fd carrying can_frames; the source does not close it
  std::string candump_log;  ///< replay this candump file instead of a live bus
  DeviceClockConfig clock;  ///< device-to-monotonic mapping and camera-to-IMU offset
};

/// Faults seen on the bus; each is logged when first counted per read.
struct CanImuFaults {
  uint64_t can_error_frames = 0;
  uint64_t bus_off = 0;
  uint64_t unknown_ids = 0;
  uint64_t short_frames = 0;
  uint64_t incomplete_samples = 0;
  uint64_t partial_packets = 0;  ///< reads that did not return a whole can_frame
  uint64_t malformed_log_lines = 0;
  uint64_t timestamp_jumps = 0;
};

class CanImuSource final : public ImuSource {
 public:
  explicit CanImuSource(CanImuConfig cfg);
  ~CanImuSource() override;
  bool start() override;
  ReadStatus read(ImuSample& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override;
  const CanImuFaults& faults() const { return faults_; }

 private:
  void handle(const can_frame& f, int64_t host_ns);
  CanImuConfig cfg_;
  CanImuDecoder decoder_;
  DeviceClock clock_;
  CandumpFileReader log_;
  bool use_log_ = false;
  int fd_ = -1;
  bool own_fd_ = false;
  std::deque<ImuSample> ready_;
  CanImuFaults faults_;
  std::string error_;
};

}  // namespace seavio::drivers
