#pragma once
/// `CameraSource` for a V4L2 capture device (USB/MIPI stereo cameras that deliver the two
/// views side by side in one GREY or YUYV image), mmap streaming I/O.
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "drivers/imu_serial/device_clock.hpp"
#include "drivers/source/reconnect_backoff.hpp"
#include "drivers/source/sources.hpp"
#include "drivers/v4l2/v4l2_device.hpp"

namespace seavio::drivers {

struct V4l2CameraConfig {
  std::string device = "/dev/video0";
  int width = 1280;  ///< full image width [px] (both views side by side), must be even
  int height = 480;  ///< [px]
  /// Preferred pixel format, "GREY" or "YUYV"; if the driver offers the other one
  /// instead, that is used (luma is taken from YUYV).
  std::string pixel_format = "GREY";
  double frame_rate_hz = 15;  ///< requested with VIDIOC_S_PARM, <= 0 = keep
  int n_buffers = 4;          ///< requested mmap buffers (the driver may grant fewer or more)
  DeviceClockConfig clock;    ///< used when the driver's timestamps are not CLOCK_MONOTONIC
  /// A device that fails while streaming (unplugged, USB reset) is reopened on this schedule.
  ReconnectBackoffConfig reconnect;
};

struct V4l2Faults {
  uint64_t frames_dropped = 0;  ///< gaps in the driver's sequence numbers
  uint64_t corrupt_frames = 0;  ///< V4L2_BUF_FLAG_ERROR or too few bytes
  uint64_t timestamp_jumps = 0;
  uint64_t reconnects = 0;      ///< the device reopened after it failed while streaming
};

class V4l2CameraSource final : public CameraSource {
 public:
  /// `device` defaults to the real POSIX device; tests pass a fake.
  explicit V4l2CameraSource(V4l2CameraConfig cfg, std::unique_ptr<V4l2Device> device = nullptr);
  ~V4l2CameraSource() override;
  bool start() override;
  ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override { return "v4l2:" + cfg_.device; }
  const V4l2Faults& faults() const { return faults_; }
  /// Negotiated format (valid after `start`): fourcc, size and row stride [bytes].
  uint32_t fourcc() const { return fourcc_; }
  int width() const { return width_; }
  int height() const { return height_; }
  int bytesPerLine() const { return stride_; }
  size_t bufferCount() const { return buffers_.size(); }

 private:
  bool fail(const std::string& what);
  /// The device failed while streaming: closes it and schedules the reopening. kError.
  ReadStatus lose(const std::string& why);
  /// While lost: reopens the device when the backoff allows, else waits up to `timeout`.
  ReadStatus reconnect(std::chrono::milliseconds timeout);
  struct Buffer {
    void* data = nullptr;
    size_t length = 0;
  };
  V4l2CameraConfig cfg_;
  std::unique_ptr<V4l2Device> dev_;
  std::vector<Buffer> buffers_;
  DeviceClock clock_;
  bool streaming_ = false;
  bool lost_ = false;
  ReconnectBackoff backoff_;
  bool have_seq_ = false;
  uint32_t last_seq_ = 0;
  uint64_t out_seq_ = 0;
  uint32_t fourcc_ = 0;
  int width_ = 0, height_ = 0, stride_ = 0;
  V4l2Faults faults_;
  std::string error_;
};

}  // namespace seavio::drivers
