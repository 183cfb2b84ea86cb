#pragma once
/// Camera and IMU sources fed by LCM messages (seavio_lcm::stereo_t / imu_t), so a running
/// daemon takes its input from `lcm-logplayer` or another process exactly as from a driver.
/// Each source owns its own LCM instance and is read by one thread.
///
/// URL "udpm://...": live messages. Add `recv_buf_size=BYTES` to the URL for raw stereo: a
/// 640 x 480 pair is ~600 kB of UDP fragments, more than Linux's default socket buffer
/// holds while the daemon is busy (the kernel caps it at net.core.rmem_max). Frames lost
/// there show as gaps in stereo_t.seq, counted by the daemon as frames_missing_upstream.
/// URL "file://LOG[?speed=S]": the log is read directly (see lcm_log_replay.hpp): clean end
/// of the log is kEnd; damage, unknown channels and undecodable messages are each one kError
/// naming the file, offset and event, and reading goes on.
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "drivers/lcm/lcm_bus.hpp"
#include "drivers/lcm/lcm_log_replay.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

/// From a file:// log it also follows the log's IMU channel (`imu_channel`) and calibration
/// message: a log in consumption order (seaviod's recorder) tells the daemon, per frame,
/// which IMU samples the recording estimator held (ImuHorizonReporter).
class LcmStereoSource : public CameraSource, public ImuHorizonReporter {
 public:
  /// @param max_queued frames kept between LCM and read(); beyond that the oldest is
  ///        discarded and counted in dropped()
  LcmStereoSource(std::string url, std::string channel, std::size_t max_queued = 4,
                  std::string imu_channel = "SEAVIO_IMU");
  bool start() override;
  ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override { return "lcm:" + channel_; }
  uint64_t dropped() const { return dropped_; }
  /// Messages that did not decode or had inconsistent sizes.
  uint64_t badMessages() const { return bad_ + (bus_ ? bus_->decodeFailures() : 0); }
  /// The log reader when replaying a file:// URL (null otherwise, or before start()).
  const LcmLogChannelReader* logReader() const { return log_ ? &*log_ : nullptr; }
  bool imuHorizon(int64_t& horizon_ns) const override;

 private:
  std::string url_, channel_, imu_channel_;
  std::size_t max_queued_;
  std::unique_ptr<LcmBus> bus_;
  std::optional<LcmLogChannelReader> log_;
  int64_t horizon_ns_ = kNoImu;  ///< of the frame last read (file:// only)
  std::deque<StereoFrame> queue_;
  uint64_t dropped_ = 0, bad_ = 0;
  std::string error_;
};

class LcmImuSource : public ImuSource {
 public:
  LcmImuSource(std::string url, std::string channel, std::size_t max_queued = 4096);
  bool start() override;
  ReadStatus read(ImuSample& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override { return "lcm:" + channel_; }
  uint64_t dropped() const { return dropped_; }
  uint64_t badMessages() const { return bad_ + (bus_ ? bus_->decodeFailures() : 0); }
  const LcmLogChannelReader* logReader() const { return log_ ? &*log_ : nullptr; }

 private:
  std::string url_, channel_;
  std::size_t max_queued_;
  std::unique_ptr<LcmBus> bus_;
  std::optional<LcmLogChannelReader> log_;
  std::deque<ImuSample> queue_;
  uint64_t dropped_ = 0, bad_ = 0;
  std::string error_;
};

}  // namespace seavio::drivers
