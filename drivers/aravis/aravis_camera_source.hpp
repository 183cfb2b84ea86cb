#pragma once
/// `CameraSource` for GigE Vision (and USB3 Vision) cameras through Aravis: a stereo pair of
/// two cameras paired by device timestamp, or one camera delivering side-by-side stereo.
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "drivers/imu_serial/device_clock.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

struct AravisCameraConfig {
  /// Aravis device id ("<vendor>-<model>-<serial>", as `arv-tool-0.8` lists) or IP address.
  std::string left_id;
  /// Second camera; empty = `left_id` delivers both halves side by side (left | right).
  std::string right_id;
  int width = 0;              ///< region width [px] per camera, 0 = keep the camera's
  int height = 0;             ///< region height [px], 0 = keep
  double exposure_us = 0;     ///< exposure time [us], <= 0 = keep the camera's setting
  double frame_rate_hz = 15;  ///< free-running rate (ignored with a trigger), <= 0 = keep
  /// Trigger source for hardware-triggered pairs (e.g. "Line1"); empty = free running.
  std::string trigger_source;
  int n_buffers = 8;    ///< stream buffers per camera
  int packet_size = 0;  ///< GVSP packet size [bytes], 0 = camera default
  /// Receive socket buffer [bytes]; 0 = ARV_GV_STREAM_SOCKET_BUFFER_AUTO (sized to payload).
  int socket_buffer_bytes = 0;
  /// Left and right frames whose mapped timestamps differ by more than this are not a pair:
  /// the older one is dropped and counted [ns]. Each camera's device clock is mapped
  /// independently, so early mapped times carry a few ms of latency jitter; keep this
  /// between that jitter and half the frame period (10 ms suits 15 fps, period 66 ms).
  int64_t pair_tolerance_ns = 10'000'000;
  /// With no frame for this long the camera is considered gone and reopened [ms].
  int reconnect_after_ms = 1000;
  /// Device-to-monotonic mapping and camera-to-IMU offset. With two cameras the first
  /// `clock.init_samples` frames of each only settle the clock and are not paired (about
  /// 1.3 s at 15 fps with the default 20, also after a reconnect).
  DeviceClockConfig clock;
};

/// Faults of the camera pair, also logged with spdlog.
struct AravisFaults {
  uint64_t frames_dropped = 0;   ///< device frame-id gaps + unpaired frames
  uint64_t unpaired_frames = 0;  ///< part of frames_dropped: no partner within tolerance
  uint64_t corrupt_frames = 0;   ///< buffers with a non-success status or wrong format/size
  uint64_t reconnects = 0;       ///< successful reopenings after a camera disappeared
  uint64_t timestamp_jumps = 0;
};

class AravisCameraSource final : public CameraSource {
 public:
  explicit AravisCameraSource(AravisCameraConfig cfg);
  ~AravisCameraSource() override;
  /// Opens and configures the camera(s) and starts acquisition.
  bool start() override;
  /// Next stereo pair; kTimeout while nothing arrives (reconnecting in the background of
  /// these calls when a camera stays silent), kError only if never started.
  ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override;
  const AravisFaults& faults() const { return faults_; }

 private:
  struct Impl;
  AravisCameraConfig cfg_;
  std::unique_ptr<Impl> impl_;
  AravisFaults faults_;
  std::string error_;
};

}  // namespace seavio::drivers
