#pragma once
/// seaviod's recorder: writes exactly the stereo pairs and IMU samples the estimator consumes
/// to a size-bounded, rotating LCM log in the standard format (lcm-logplayer plays it).
///
/// Every file begins with the calibration the daemon runs with (seavio_lcm::calibration_t,
/// IMU_ORDER_CONSUMED), so each file replays alone (`seavio replay`). Events follow in the
/// order the estimator consumed them: an IMU sample when the estimator takes it from the IMU
/// ring, a frame when the estimator begins its odometry, so the IMU events before a frame
/// are exactly the samples the estimator held for it; event times are the sample stamps [us].
///
/// Off the frame path: the estimator only moves items into a fixed-capacity SPSC ring (never
/// waits, never allocates beyond the frame's image references); the writer thread, at
/// background priority, encodes and writes. A full ring, a failed write or a full disk drops
/// the item and is counted (status_t.record_*), never fatal; after a write failure the writer
/// waits a second before it starts a new file.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/common/types.hpp"
#include "daemon/record_config.hpp"
#include "daemon/spsc_ring.hpp"
#include "drivers/lcm/calibration_msg.hpp"

namespace seavio::drivers {
class LcmLogWriter;
}

namespace seavio::daemon {

struct RecorderCounts {
  uint64_t frames = 0;          ///< frames written
  uint64_t imu_samples = 0;     ///< IMU samples written
  uint64_t dropped = 0;         ///< frames and samples not written: ring full or write failed
  uint64_t write_failures = 0;  ///< failed writes and files that could not be opened
  uint64_t files = 0;           ///< files begun
};

class Recorder {
 public:
  /// @param calibration the calibration the estimator runs with (written IMU_ORDER_CONSUMED)
  Recorder(RecordConfig config, drivers::LogCalibration calibration, std::string stereo_channel,
           std::string imu_channel, std::string calibration_channel);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  /// Starts the writer thread; `on_thread_start` runs first on it (scheduling).
  void start(std::function<void()> on_thread_start);
  /// Estimator thread only; never waits. The frame's images are shared, not copied: the
  /// estimator never writes into them.
  void frame(const StereoFrame& f);
  void imu(const ImuSample& s);
  /// Writes everything queued, closes the file, joins. Idempotent.
  void stop();

  RecorderCounts counts() const;
  /// Files of this recording, oldest first (the last one is being written).
  std::vector<std::string> files() const;
  /// File number `index` of `path`: dive.lcmlog -> dive.0003.lcmlog.
  static std::string fileName(const std::string& path, uint64_t index);

 private:
  struct Item {
    bool is_frame = false;
    StereoFrame frame;
    ImuSample imu;
  };
  void writerLoop();
  void write(const Item& item);
  bool openNext();
  bool writeEncoded(const std::string& channel, const std::vector<uint8_t>& data, int64_t t_us);

  RecordConfig cfg_;
  drivers::LogCalibration calibration_;
  std::string stereo_channel_, imu_channel_, calibration_channel_;
  SpscRing<Item> ring_;
  std::atomic<std::size_t> frames_queued_{0};
  std::atomic<bool> stop_{false};
  std::atomic<bool> running_{false};
  std::thread thread_;

  std::atomic<uint64_t> frames_{0}, imu_samples_{0}, dropped_{0}, write_failures_{0}, files_{0};

  mutable std::mutex kept_mutex_;
  std::deque<uint64_t> kept_;  ///< indexes of the files on disk, oldest first

  // Writer thread only.
  std::unique_ptr<drivers::LcmLogWriter> log_;
  uint64_t next_index_ = 0;
  std::size_t bytes_ = 0;      ///< bytes in the current file
  std::chrono::steady_clock::time_point retry_after_{};
  std::vector<uint8_t> buf_;
};

}  // namespace seavio::daemon
