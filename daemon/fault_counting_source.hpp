#pragma once
/// How each device driver's own fault counters fold into the daemon's status fields,
/// and the source wrapper that keeps a copy of them for the status thread. Used by
/// daemon/source_factory.cpp for every live driver, and by the fault tests on the same drivers
/// built from a file descriptor (tests/daemon/daemon_faults_test.cpp).
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <type_traits>

#include "daemon/health.hpp"
#include "drivers/imu_can/can_imu_source.hpp"
#include "drivers/imu_serial/serial_imu_source.hpp"
#include "drivers/source/sources.hpp"
#include "drivers/v4l2/v4l2_camera_source.hpp"
#ifdef SEAVIO_HAVE_ARAVIS
#include "drivers/aravis/aravis_camera_source.hpp"
#endif
#ifdef SEAVIO_HAVE_LIBCAMERA
#include "drivers/libcamera/libcamera_camera_source.hpp"
#endif

namespace seavio::daemon {

inline DriverFaults foldFaults(const drivers::CanImuFaults& f) {
  DriverFaults d;
  // Everything the bus itself got wrong is one status field: error frames, bus-off, frames
  // the profile does not know, short frames, samples missing a part, bad candump lines.
  d.imu_bus_errors =
      f.can_error_frames + f.bus_off + f.unknown_ids + f.short_frames + f.incomplete_samples + f.malformed_log_lines;
  d.imu_partial_packets = f.partial_packets;
  d.imu_reconnects = f.reconnects;
  d.timestamp_jumps = f.timestamp_jumps;
  return d;
}

inline DriverFaults foldFaults(const drivers::SerialImuFaults& f) {
  DriverFaults d;
  d.imu_checksum_errors = f.checksum_errors;
  d.imu_garbage_bytes = f.garbage_bytes + f.unsupported_packets;
  d.imu_partial_packets = f.partial_packets;
  d.imu_reconnects = f.reconnects;
  d.timestamp_jumps = f.timestamp_jumps;
  return d;
}

inline DriverFaults foldFaults(const drivers::V4l2Faults& f) {
  DriverFaults d;
  d.camera_reconnects = f.reconnects;
  d.camera_lost_frames = f.frames_dropped;
  d.camera_corrupt_frames = f.corrupt_frames;
  d.timestamp_jumps = f.timestamp_jumps;
  return d;
}

#ifdef SEAVIO_HAVE_ARAVIS
inline DriverFaults foldFaults(const drivers::AravisFaults& f) {
  DriverFaults d;
  d.camera_reconnects = f.reconnects;
  d.camera_unpaired_frames = f.unpaired_frames;
  // Aravis counts an unpaired frame as dropped too: the status keeps the two apart.
  d.camera_lost_frames = f.frames_dropped - f.unpaired_frames;
  d.camera_corrupt_frames = f.corrupt_frames;
  d.timestamp_jumps = f.timestamp_jumps;
  return d;
}
#endif

#ifdef SEAVIO_HAVE_LIBCAMERA
inline DriverFaults foldFaults(const drivers::LibcameraFaults& f) {
  DriverFaults d;
  d.camera_reconnects = f.reconnects;
  d.camera_lost_frames = f.frames_dropped;
  d.camera_corrupt_frames = f.corrupt_frames;
  return d;
}
#endif

/// Forwards to a driver and keeps a folded copy of its fault counters, taken on the reading
/// thread after every call, so the status thread never touches the driver itself.
template <class Source, class Sample, class Driver>
class FaultCountingSource final : public Source, public FaultReporter {
 public:
  explicit FaultCountingSource(std::unique_ptr<Driver> d) : d_(std::move(d)) {}
  bool start() override {
    const bool ok = d_->start();
    snapshot();
    return ok;
  }
  drivers::ReadStatus read(Sample& out, std::chrono::milliseconds timeout) override {
    const drivers::ReadStatus st = d_->read(out, timeout);
    snapshot();
    return st;
  }
  void stop() override { d_->stop(); }
  std::string lastError() const override { return d_->lastError(); }
  std::string name() const override { return d_->name(); }
  DriverFaults faults() const override {
    std::lock_guard<std::mutex> lock(m_);
    return snap_;
  }

 private:
  void snapshot() {
    const DriverFaults f = foldFaults(d_->faults());
    std::lock_guard<std::mutex> lock(m_);
    snap_ = f;
  }
  std::unique_ptr<Driver> d_;
  mutable std::mutex m_;
  DriverFaults snap_;
};

/// `driver` behind FaultCountingSource, as the camera or IMU source it is.
template <class Driver>
auto withFaultCounting(std::unique_ptr<Driver> driver) {
  if constexpr (std::is_base_of_v<drivers::CameraSource, Driver>) {
    return std::unique_ptr<drivers::CameraSource>(
        std::make_unique<FaultCountingSource<drivers::CameraSource, StereoFrame, Driver>>(std::move(driver)));
  } else {
    static_assert(std::is_base_of_v<drivers::ImuSource, Driver>, "a camera or IMU driver");
    return std::unique_ptr<drivers::ImuSource>(
        std::make_unique<FaultCountingSource<drivers::ImuSource, ImuSample, Driver>>(std::move(driver)));
  }
}

}  // namespace seavio::daemon
