#pragma once
/// `ImuSource` for an IMU on CAN: a SocketCAN raw socket on a named interface, any
/// already-open fd that carries whole `struct can_frame`s (tests use a SOCK_SEQPACKET
/// socketpair), or a candump log replayed as fast as it is read.
#include <chrono>
#include <deque>
#include <functional>
#include <string>
#include <vector>

#include "drivers/imu_can/can_imu_decoder.hpp"
#include "drivers/imu_can/can_id_filter.hpp"
#include "drivers/imu_can/candump_reader.hpp"
#include "drivers/imu_serial/device_clock.hpp"
#include "drivers/source/reconnect_backoff.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

struct CanImuConfig {
  CanProfile profile;
  std::string interface;    ///< SocketCAN interface, e.g. "can0" (used if `fd` < 0 and no log)
  int fd = -1;              ///< an open fd carrying can_frames; the source does not close it
  std::string candump_log;  ///< replay this candump file instead of a live bus
  DeviceClockConfig clock;  ///< device-to-monotonic mapping and camera-to-IMU offset
  /// A lost bus (interface down or removed, socket error) is reopened on this schedule.
  ReconnectBackoffConfig reconnect;
  /// Opens the bus for `interface` and returns an fd the source then owns, or -1 with
  /// `error`. Empty = a CAN_RAW socket with the profile's kernel ID filters. Tests give a
  /// socketpair end here: the kernels they run on have no CAN (not even vcan).
  std::function<int(std::string& error)> open_bus;
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
  /// Frames of other nodes that reached user space anyway (an fd or a log without the
  /// kernel's ID filter): skipped, not a fault of the bus.
  uint64_t foreign_frames = 0;
  uint64_t reconnects = 0;  ///< the bus reopened after it was lost
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
  /// Opens the live bus (open_bus or a filtered CAN_RAW socket on `interface`).
  bool openBus();
  /// The owned bus failed: closes it and schedules the reopening. Returns kError.
  ReadStatus lose(const std::string& why);
  /// While the bus is lost: reopens it when the backoff allows, else waits up to `timeout`.
  ReadStatus reconnect(std::chrono::milliseconds timeout);
  CanImuConfig cfg_;
  std::vector<can_filter> filters_;
  ReconnectBackoff backoff_;
  bool lost_ = false;
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
