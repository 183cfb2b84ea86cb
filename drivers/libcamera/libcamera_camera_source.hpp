#pragma once
/// `CameraSource` for cameras behind libcamera (CSI stereo modules on embedded boards) that
/// deliver both views side by side in one image. Built only when libcamera is found
/// (Debian 12 ships 0.0.3, whose API this targets).
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "drivers/source/reconnect_backoff.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

struct LibcameraConfig {
  /// libcamera camera id; empty = the first camera found.
  std::string camera_id;
  int width = 1280;            ///< full side-by-side width [px], even
  int height = 480;            ///< [px]
  int n_buffers = 4;           ///< requests kept in flight
  int64_t time_offset_ns = 0;  ///< camera-to-IMU offset added to SensorTimestamp [ns]
  /// A camera that disconnects (libcamera's Camera::disconnected) is reopened on this schedule.
  ReconnectBackoffConfig reconnect;
};

struct LibcameraFaults {
  uint64_t frames_dropped = 0;  ///< sequence gaps
  uint64_t corrupt_frames = 0;  ///< FrameError / cancelled requests
  uint64_t reconnects = 0;      ///< the camera reopened after it disconnected
};

class LibcameraCameraSource final : public CameraSource {
 public:
  explicit LibcameraCameraSource(LibcameraConfig cfg);
  ~LibcameraCameraSource() override;
  /// Starts the camera manager, acquires and configures the camera (R8, or the luma
  /// plane of YUYV/NV12/YUV420), allocates buffers and queues requests.
  bool start() override;
  ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override;
  std::string name() const override {
    return "libcamera:" + (cfg_.camera_id.empty() ? std::string("first") : cfg_.camera_id);
  }
  LibcameraFaults faults() const;

 private:
  struct Impl;
  /// While the camera is lost: reopens it when the backoff allows, else waits up to `timeout`.
  ReadStatus reconnect(std::chrono::milliseconds timeout);
  LibcameraConfig cfg_;
  ReconnectBackoff backoff_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace seavio::drivers
